//! Restarts through the checkpoint file, in new processes: a run stopped at a checkpoint (or
//! killed with SIGKILL after it) and resumed with `--resume` ends in the uninterrupted run's
//! state bit for bit, with the same records; the killed run's MCAP stays readable.

mod common;
use common::*;
use std::time::{Duration, Instant};

const SCHEMES: [&str; 3] = ["euler", "predictor_corrector", "dg"];

#[test]
fn resume_through_the_checkpoint_file_is_bit_for_bit() {
    resume_bit_for_bit("resume", &cavity(0.2));
}

/// The same with mirror-ghost walls, which are placed anew from the fluid before every step
/// (and renumbered with it, `reorder_every = 3`).
#[test]
fn resume_with_ghost_walls_is_bit_for_bit() {
    let text = cavity(0.2).replace("[cavity]\n", "[cavity]\nwall_model = \"ghost\"\n");
    assert!(text.contains("wall_model"));
    resume_bit_for_bit("resume_ghost", &text);
}

fn resume_bit_for_bit(name: &str, scene_text: &str) {
    let dir = scratch(name);
    let s = scene(&dir, "c", scene_text);
    let (a, b) = (dir.join("a"), dir.join("b"));
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        a.to_str().unwrap(),
        "--checkpoint-every",
        "5",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // Stop at t = 0.1 (step 10), then continue in a new process from the file.
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        b.to_str().unwrap(),
        "--checkpoint-every",
        "5",
        "--t-end",
        "0.1",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        b.to_str().unwrap(),
        "--checkpoint-every",
        "5",
        "--resume",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("resuming from step 10"), "{}", text(&o));
    for scheme in SCHEMES {
        let ca = std::fs::read(a.join(format!("c_{scheme}.checkpoint"))).unwrap();
        let cb = std::fs::read(b.join(format!("c_{scheme}.checkpoint"))).unwrap();
        assert!(
            ca == cb,
            "{scheme}: the resumed run's final state differs from the uninterrupted run's"
        );
        let ra = rows_without_timing(&a.join(format!("c_{scheme}.csv")));
        let rb = rows_without_timing(&b.join(format!("c_{scheme}.csv")));
        assert_eq!(ra, rb, "{scheme}: records differ");
        // The snapshot due at t = 0.05, before the checkpoint, is there (written as it came).
        assert!(b.join(format!("c_{scheme}_density_t0.050.csv")).exists());
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `dgsph run SCENE` with a checkpoint every 7 steps, once uninterrupted (`dir/a`) and once
/// stopped at `t_end_14` (step 14) and resumed in a new process (`dir/b`): every scheme's final
/// checkpoint and records (timings aside) are the same bits. Removes `dir`.
fn interrupted_at_step_14_resumes_bit_for_bit(
    dir: &std::path::Path,
    s: &std::path::Path,
    t_end_14: &str,
) {
    let (a, b) = (dir.join("a"), dir.join("b"));
    let run = |out: &std::path::Path, extra: &[&str]| {
        let mut args = vec![
            "run",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--checkpoint-every",
            "7",
        ];
        args.extend_from_slice(extra);
        let o = dgsph(&args);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        o
    };
    run(&a, &[]);
    run(&b, &["--t-end", t_end_14]);
    let o = run(&b, &["--resume"]);
    assert!(text(&o).contains("resuming from step 14"), "{}", text(&o));
    for scheme in SCHEMES {
        let ca = std::fs::read(a.join(format!("c_{scheme}.checkpoint"))).unwrap();
        let cb = std::fs::read(b.join(format!("c_{scheme}.checkpoint"))).unwrap();
        assert!(ca == cb, "{scheme}: the resumed run's final state differs");
        let ra = rows_without_timing(&a.join(format!("c_{scheme}.csv")));
        let rb = rows_without_timing(&b.join(format!("c_{scheme}.csv")));
        assert_eq!(ra, rb, "{scheme}: records differ");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn resume_with_a_kept_amg_hierarchy_is_bit_for_bit() {
    // AMG keeps its hierarchy for up to 10 solves; checkpoints every 7 steps fall inside that
    // age, so the uninterrupted run must start its solver afresh after each checkpoint as the
    // resumed run (a new process) does. 20² cavity: two AMG levels.
    let dir = scratch("resume_amg");
    let text_scene = cavity(0.25)
        .replace("dx = 0.1", "dx = 0.05")
        .replace("dt = 0.01", "dt = 0.0125")
        .replace(
            "solver_tolerance = 1e-8",
            "solver_tolerance = 1e-8\nsolver = \"bicgstab_amg\"",
        );
    let s = scene(&dir, "c", &text_scene);
    interrupted_at_step_14_resumes_bit_for_bit(&dir, &s, "0.175");
}

#[test]
fn resume_of_a_free_surface_flow_is_bit_for_bit() {
    // A jittered tank under gravity with the flow scenes' defaults: besides the projection's
    // solver, the density correction's second solve keeps an AMG hierarchy, which a checkpoint
    // (every 7 steps, inside the hierarchy's 10-solve age) must forget as a resumed run (a new
    // process) does; at 64 × 40 particles the hierarchy has levels to keep (at 32 × 20 this test
    // passed with the correction's solver left unreset). Fixed step: step 14 is t = 0.028.
    let dir = scratch("resume_flow");
    let text_scene = "dim = 2\ndx = 0.0125\nkernel = \"wendland_c2\"\ndt = 2e-3\nt_end = 0.05\n\
        schemes = [\"euler\", \"predictor_corrector\", \"dg\"]\n\
        [time_step]\nauto = false\n\
        [[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.8, 0.5]\nhydrostatic = true\njitter = 0.1\n\
        [[wall]]\nmin = [0.0, 0.0]\nmax = [0.8, 0.8]\nopen = [\"+y\"]\n\
        [free_surface]\n\
        [effects]\ngravity = [0.0, -9.81, 0.0]\nshifting = { coefficient = 2.0 }\n";
    let s = scene(&dir, "c", text_scene);
    interrupted_at_step_14_resumes_bit_for_bit(&dir, &s, "0.028");
}

#[test]
fn kill_9_then_resume_equals_the_uninterrupted_run() {
    let dir = scratch("kill");
    // Long enough to be killed mid-run: 20² cavity, 3000 steps of DG.
    let text_scene = cavity(30.0).replace("dx = 0.1", "dx = 0.05").replace(
        "schemes = [\"euler\", \"predictor_corrector\", \"dg\"]",
        "schemes = [\"dg\"]",
    );
    let s = scene(&dir, "k", &text_scene);
    let (straight, killed) = (dir.join("straight"), dir.join("killed"));
    // The run to be killed, with --t-end short enough for the straight one to finish quickly.
    let t_end = "2.0";
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_dgsph"))
        .args([
            "run",
            s.to_str().unwrap(),
            "--out",
            killed.to_str().unwrap(),
            "--checkpoint-every",
            "25",
            "--t-end",
            t_end,
        ])
        .env("RAYON_NUM_THREADS", "2")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let csv = killed.join("k_dg.csv");
    let ck = killed.join("k_dg.checkpoint");
    let t0 = Instant::now();
    // Wait for a checkpoint and for records past it, then SIGKILL.
    loop {
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "the run never got going"
        );
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the run finished before it could be killed: {status}");
        }
        let rows = std::fs::read_to_string(&csv)
            .map(|t| t.lines().count())
            .unwrap_or(0);
        if ck.exists() && rows > 60 {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let written = std::fs::read_to_string(&csv).unwrap().lines().count() - 1;
    // The killed run's MCAP reads back (streaming) up to its last complete chunk: at least
    // every record but the one being written when the kill came.
    let bytes = std::fs::read(killed.join("k_dg.mcap")).unwrap();
    let mut metrics = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        match m {
            Ok(m) if m.channel.topic == "/metrics" => metrics += 1,
            Ok(_) => {}
            Err(_) => break, // the unfinished tail
        }
    }
    assert!(
        metrics + 1 >= written,
        "MCAP holds {metrics} of {written} records"
    );
    // Resume, and run the same scene straight through.
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        killed.to_str().unwrap(),
        "--checkpoint-every",
        "25",
        "--t-end",
        t_end,
        "--resume",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        straight.to_str().unwrap(),
        "--checkpoint-every",
        "25",
        "--t-end",
        t_end,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let a = std::fs::read(straight.join("k_dg.checkpoint")).unwrap();
    let b = std::fs::read(&ck).unwrap();
    assert!(
        a == b,
        "killed-and-resumed state differs from the uninterrupted run"
    );
    assert_eq!(
        rows_without_timing(&straight.join("k_dg.csv")),
        rows_without_timing(&csv)
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn damaged_or_foreign_checkpoints_are_refused() {
    let dir = scratch("damaged");
    let s = scene(&dir, "c", &cavity(0.05));
    let out = dir.join("o");
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--checkpoint-every",
        "5",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let ck = out.join("c_dg.checkpoint");
    let good = std::fs::read(&ck).unwrap();
    let resume = || {
        dgsph(&[
            "run",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--resume",
            "--t-end",
            "0.1",
        ])
    };
    // A flipped bit.
    let mut bad = good.clone();
    let k = bad.len() / 2;
    bad[k] ^= 1;
    std::fs::write(&ck, &bad).unwrap();
    let o = resume();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("checksum"), "{}", text(&o));
    // Truncated.
    std::fs::write(&ck, &good[..good.len() / 3]).unwrap();
    let o = resume();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    // Written under other physics.
    std::fs::write(&ck, &good).unwrap();
    let other = scene(
        &dir,
        "c",
        &cavity(0.05).replace("reynolds = 100", "reynolds = 400"),
    );
    let o = dgsph(&[
        "run",
        other.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--resume",
        "--t-end",
        "0.1",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("cavity differs"), "{}", text(&o));
    // No checkpoint at all.
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        dir.join("empty").to_str().unwrap(),
        "--resume",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("no checkpoint"), "{}", text(&o));
    std::fs::remove_dir_all(&dir).ok();
}

/// A checkpoint records what its build resolved the scene's numerics to (a flow scene's
/// defaults: here the hyperviscosity and the automatic step it binds), and a run resumes only
/// where this build resolves the same: a checkpoint whose record says otherwise (a default
/// changed between builds) or says nothing (written before the record existed) is refused with
/// exit 2, naming the field, and the same checkpoint re-encoded unchanged still resumes.
#[test]
fn checkpoints_of_other_numerics_are_refused() {
    use sph_integrators::Checkpoint;
    let dir = scratch("numerics");
    let text_scene = "dim = 2\ndx = 0.05\nkernel = \"wendland_c2\"\ndt = 2e-3\nt_end = 0.02\n\
        schemes = [\"euler\"]\n\
        [[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.4, 0.3]\nhydrostatic = true\n\
        [[wall]]\nmin = [0.0, 0.0]\nmax = [0.4, 0.5]\nopen = [\"+y\"]\n\
        [free_surface]\n\
        [effects]\ngravity = [0.0, -9.81, 0.0]\n";
    let s = scene(&dir, "c", text_scene);
    let out = dir.join("o");
    let run = |extra: &[&str]| {
        let mut args = vec!["run", s.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        dgsph(&args)
    };
    let o = run(&["--checkpoint-every", "3", "--t-end", "0.01"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let ck = out.join("c_euler.checkpoint");
    let good = Checkpoint::decode(&std::fs::read(&ck).unwrap()).unwrap();
    let meta: serde_json::Value = serde_json::from_str(&good.meta).unwrap();
    let numerics = meta["numerics"]
        .as_str()
        .expect("the checkpoint records its numerics");
    assert!(numerics.contains("Hyperviscosity"), "{numerics}");
    let with_meta = |meta: &serde_json::Value| {
        let mut c = good.clone();
        c.meta = serde_json::to_string(meta).unwrap();
        std::fs::write(&ck, c.encode()).unwrap();
    };
    let resume = || run(&["--resume", "--t-end", "0.02"]);
    // Another build's default: twice the hyperviscosity.
    let speed = numerics
        .split("speed: ")
        .nth(1)
        .and_then(|r| r.split([',', ' ']).next())
        .expect("a hyperviscous speed");
    let doubled = 2.0 * speed.parse::<f64>().unwrap();
    let mut other = meta.clone();
    other["numerics"] = numerics.replacen(speed, &format!("{doubled:?}"), 1).into();
    with_meta(&other);
    let o = resume();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    println!("{}", text(&o));
    assert!(
        text(&o).contains("a default changed") && text(&o).contains("speed"),
        "{}",
        text(&o)
    );
    // A build that did not record them.
    let mut old = meta.clone();
    old.as_object_mut().unwrap().remove("numerics");
    with_meta(&old);
    let o = resume();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("did not record its resolved numerics"),
        "{}",
        text(&o)
    );
    // The record as written: resumes.
    with_meta(&meta);
    let o = resume();
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    std::fs::remove_dir_all(&dir).ok();
}
