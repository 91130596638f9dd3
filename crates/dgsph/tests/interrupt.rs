//! Interrupted runs through the binary, as users meet them: SIGINT stops a three-scheme run
//! after a step with a checkpoint and an `interrupted` record (exit 130); SIGKILL during the
//! second scheme; `--resume` then finishes exactly what was unfinished, leaves finished schemes'
//! files untouched, and every `run.json` equals the uninterrupted run's (timings aside); a
//! second `--resume` does nothing and says so. SIGTERM stops a run the same way (exit 143); a
//! second signal ends it at once. Also: a second run into a directory in use is refused, a
//! closed stdout does not stop a run, a file-size limit is an output error, and an impossible
//! thread count is bad input.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const SCHEMES: [&str; 3] = ["euler", "predictor_corrector", "dg"];

/// A 20² cavity, three schemes of 1200 steps (about 1.5 s each on one core).
fn long_cavity() -> String {
    cavity(12.0).replace("dx = 0.1", "dx = 0.05")
}

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_dgsph"))
        .args(args)
        .env("RAYON_NUM_THREADS", "2")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn rows(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .map(|t| t.lines().count())
        .unwrap_or(0)
}

/// Waits until `ready()` holds (the child still running), at most a minute.
fn wait_for(child: &mut Child, what: &str, ready: impl Fn() -> bool) {
    let t0 = Instant::now();
    while !ready() {
        assert!(t0.elapsed() < Duration::from_secs(60), "never: {what}");
        if let Some(s) = child.try_wait().unwrap() {
            panic!("the run ended ({s}) before {what}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn signal(child: &Child, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

/// A run record without its timings (`wall_s`, `phases`, the `wall_seconds` result).
fn untimed_record(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("wall_s");
    o.remove("phases");
    o["results"].as_object_mut().unwrap().remove("wall_seconds");
    v
}

/// Every file of `dir` (but the lock) with its bytes.
fn contents(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| !p.ends_with(".dgsph.lock"))
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    v.sort();
    v
}

fn assert_same_runs(straight: &Path, resumed: &Path) {
    for scheme in SCHEMES {
        let record = format!("k_{scheme}.run.json");
        assert_eq!(
            untimed_record(&resumed.join(&record)),
            untimed_record(&straight.join(&record)),
            "{scheme}: the resumed run's record differs from the uninterrupted run's"
        );
        let csv = format!("k_{scheme}.csv");
        assert_eq!(
            rows_without_timing(&resumed.join(&csv)),
            rows_without_timing(&straight.join(&csv)),
            "{scheme}: records differ"
        );
    }
}

#[test]
fn interrupted_and_killed_runs_resume_to_the_uninterrupted_run() {
    let dir = scratch("interrupt");
    let s = scene(&dir, "k", &long_cavity());
    let s = s.to_str().unwrap();
    let out = |name: &str| dir.join(name);
    let straight = out("straight");
    let o = dgsph(&[
        "run",
        s,
        "--out",
        straight.to_str().unwrap(),
        "--checkpoint-every",
        "25",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let run = |dir: &Path, extra: &[&str]| {
        let mut a = vec![
            "run",
            s,
            "--out",
            dir.to_str().unwrap(),
            "--checkpoint-every",
            "25",
        ];
        a.extend_from_slice(extra);
        a.iter().map(|x| x.to_string()).collect::<Vec<_>>()
    };
    let args = |v: &[String]| v.iter().map(String::as_str).collect::<Vec<_>>().join(" ");
    let resume = |dir: &Path| {
        let v = run(dir, &["--resume"]);
        dgsph(&v.iter().map(String::as_str).collect::<Vec<_>>())
    };

    // SIGINT during the first scheme: it stops after a step, with a checkpoint and a record.
    let a = out("sigint");
    let v = run(&a, &[]);
    let mut child = spawn(&v.iter().map(String::as_str).collect::<Vec<_>>());
    wait_for(&mut child, "euler records", || {
        rows(&a.join("k_euler.csv")) > 40
    });
    signal(&child, "-INT");
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{}: {err}", args(&v));
    assert!(err.contains("SIGINT") && err.contains("--resume"), "{err}");
    let rec = untimed_record(&a.join("k_euler.run.json"));
    assert_eq!(rec["status"], "interrupted");
    assert!(a.join("k_euler.checkpoint").exists());
    assert!(
        !a.join("k_predictor_corrector.csv").exists(),
        "the next scheme started"
    );
    let o = resume(&a);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("k_euler: resuming from step"),
        "{}",
        text(&o)
    );
    assert!(
        text(&o).contains("k_dg: no checkpoint; starting at t = 0"),
        "{}",
        text(&o)
    );
    assert_same_runs(&straight, &a);
    // A second --resume: nothing to do, nothing touched.
    let before = contents(&a);
    let o = resume(&a);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("nothing to resume"), "{}", text(&o));
    assert!(contents(&a) == before, "a no-op resume changed files");

    // SIGKILL during the second scheme, past its first checkpoint.
    let b = out("kill");
    let v = run(&b, &[]);
    let mut child = spawn(&v.iter().map(String::as_str).collect::<Vec<_>>());
    let ck = b.join("k_predictor_corrector.checkpoint");
    wait_for(&mut child, "a predictor-corrector checkpoint", || {
        ck.exists() && rows(&b.join("k_predictor_corrector.csv")) > 30
    });
    child.kill().unwrap();
    child.wait().unwrap();
    let euler_files = || -> Vec<_> {
        contents(&b)
            .into_iter()
            .filter(|(p, _)| p.to_string_lossy().contains("k_euler"))
            .collect()
    };
    let euler = euler_files();
    let o = resume(&b);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("k_euler: finished earlier"),
        "{}",
        text(&o)
    );
    assert!(
        euler == euler_files(),
        "the finished scheme's files changed"
    );
    assert_same_runs(&straight, &b);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_directory_in_use_is_refused_and_a_closed_stdout_does_not_stop_a_run() {
    let dir = scratch("lock");
    let s = scene(&dir, "k", &long_cavity());
    let s = s.to_str().unwrap();
    let o1 = dir.join("o");
    let mut first = spawn(&["run", s, "--out", o1.to_str().unwrap()]);
    wait_for(&mut first, "records", || rows(&o1.join("k_euler.csv")) > 2);
    let o = dgsph(&["run", s, "--out", o1.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("in use by another dgsph run"),
        "{}",
        text(&o)
    );
    // SIGTERM stops it like SIGINT: after a step, with its record; exit 128 + 15.
    signal(&first, "-TERM");
    let o = first.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(143), "{err}");
    assert!(err.contains("SIGTERM"), "{err}");
    assert_eq!(
        untimed_record(&o1.join("k_euler.run.json"))["status"],
        "interrupted"
    );
    // Once the first run is gone, the directory is free.
    let short = scene(&dir, "short", &cavity(0.05));
    let short = short.to_str().unwrap();
    let o = dgsph(&["run", short, "--out", o1.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));

    // stdout a pipe whose reader is gone (`dgsph run … | head -0`): every write fails with
    // EPIPE, and every scheme still runs.
    let closed = || {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        writer
    };
    let o2 = dir.join("pipe");
    let o = Command::new(env!("CARGO_BIN_EXE_dgsph"))
        .args(["run", short, "--out", o2.to_str().unwrap()])
        .env("RAYON_NUM_THREADS", "2")
        .stdout(closed())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    for scheme in SCHEMES {
        assert!(
            o2.join(format!("short_{scheme}.run.json")).exists(),
            "{scheme}"
        );
    }
    let o = Command::new(env!("CARGO_BIN_EXE_dgsph"))
        .args(["check", short])
        .stdout(closed())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_impossible_thread_count_is_bad_input() {
    for value in ["100000", "many"] {
        let o = Command::new(env!("CARGO_BIN_EXE_dgsph"))
            .args(["check", "no-such-scene.toml"])
            .env("RAYON_NUM_THREADS", value)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{value}: {}", text(&o));
        assert!(text(&o).contains("RAYON_NUM_THREADS"), "{}", text(&o));
    }
}

/// A file-size limit (`ulimit -f`) makes a write fail: the run ends with exit 4 naming the file,
/// instead of dying by SIGXFSZ without a word.
#[cfg(unix)]
#[test]
fn a_file_size_limit_is_an_output_error() {
    let dir = scratch("fsize");
    let s = scene(&dir, "c", &cavity(0.2));
    let out = dir.join("o");
    let o = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -f 16; exec '{}' run '{}' --out '{}'",
            env!("CARGO_BIN_EXE_dgsph"),
            s.display(),
            out.display()
        ))
        .env("RAYON_NUM_THREADS", "2")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", text(&o));
    assert!(
        text(&o).contains("writing results") && text(&o).contains(&*out.to_string_lossy()),
        "{}",
        text(&o)
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A second SIGINT ends the process at once (exit 130), without waiting for the step in
/// progress: a 250 000-particle cavity whose steps take seconds, both signals sent just after a
/// step's record appeared. The graceful stop would have written `run.json` after the step.
#[test]
fn a_second_signal_exits_at_once() {
    let dir = scratch("twice");
    let text = cavity(1.0)
        .replace("dx = 0.1", "dx = 0.002")
        .replace("dt = 0.01", "dt = 1e-4")
        .replace(
            "schemes = [\"euler\", \"predictor_corrector\", \"dg\"]",
            "schemes = [\"euler\"]",
        )
        .replace("snapshots = [0.05]", "snapshots = [0.05]\nsample_every = 1");
    let s = scene(&dir, "big", &text);
    let out = dir.join("o");
    let mut child = spawn(&["run", s.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    // Header, the initial record and step 1's: step 2 has just begun.
    wait_for(&mut child, "step 1's record", || {
        rows(&out.join("big_euler.csv")) >= 3
    });
    signal(&child, "-INT");
    std::thread::sleep(Duration::from_millis(10));
    let t0 = Instant::now();
    signal(&child, "-INT");
    let o = child.wait_with_output().unwrap();
    let waited = t0.elapsed().as_secs_f64();
    assert_eq!(
        o.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        !out.join("big_euler.run.json").exists(),
        "the step finished and the run stopped gracefully ({waited:.2} s after the second signal)"
    );
    std::fs::remove_dir_all(&dir).ok();
}
