//! `cargo xtask interleave` through the real binary, on shell commands whose output and
//! duration are known: the runs alternate A, B, A, B; each run's step time is the figure its
//! command printed; the logs hold each command's output; a failing command stops the series
//! with exit 3 (a failed run) naming the run, and leaves the runs before it in the CSV; a bad
//! label exits 2 (bad input).

mod common;

use common::{scratch, xtask};

/// CSV rows as (run, side, label, wall, s/step, figures).
fn rows(dir: &std::path::Path) -> Vec<(usize, String, String, f64, String, usize)> {
    let text = std::fs::read_to_string(dir.join("interleave.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("run,side,label,wall_s,s_per_step,step_figures,load1_before")
    );
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 7, "{l}");
            (
                f[0].parse().unwrap(),
                f[1].to_string(),
                f[2].to_string(),
                f[3].parse().unwrap(),
                f[4].to_string(),
                f[5].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn runs_alternate_and_the_table_gives_the_ratio_of_the_printed_step_times() {
    let dir = scratch("interleave");
    let out = dir.join("ab");
    let (code, text, _) = xtask(&[
        "interleave",
        "--a",
        "echo 'fast  iters/step 6.0  0.0200 s/step  5e5 particle-steps/s'",
        "--b",
        "sleep 0.3; echo 'slow 0.0300 s/step'; echo 'second 9.0 s/step' >&2",
        "--label-a",
        "new",
        "--label-b",
        "old",
        "--pairs",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    let r = rows(&out);
    let order: Vec<(usize, &str, &str)> = r
        .iter()
        .map(|x| (x.0, x.1.as_str(), x.2.as_str()))
        .collect();
    assert_eq!(
        order,
        [
            (1, "A", "new"),
            (2, "B", "old"),
            (3, "A", "new"),
            (4, "B", "old")
        ]
    );
    for x in &r {
        let (step, figures): (f64, usize) = if x.1 == "A" { (0.02, 1) } else { (0.03, 2) };
        assert_eq!(x.4.parse::<f64>().unwrap(), step, "{x:?}");
        assert_eq!(x.5, figures, "{x:?}");
        if x.1 == "B" {
            assert!(x.3 >= 0.3, "B sleeps 0.3 s: wall {}", x.3);
        }
    }
    // Each log holds its command's output, standard error included.
    let log = std::fs::read_to_string(out.join("run-4-old.log")).unwrap();
    assert!(
        log.contains("slow 0.0300 s/step") && log.contains("second 9.0"),
        "{log}"
    );
    let md = std::fs::read_to_string(out.join("interleave.md")).unwrap();
    let step_row = md
        .lines()
        .find(|l| l.starts_with("| s/step, mean ± SD"))
        .unwrap_or_else(|| panic!("no step row in\n{md}"));
    let cells: Vec<&str> = step_row.split('|').map(str::trim).collect();
    assert_eq!(
        &cells[2..6],
        [
            "0.0200 ± 0.0000",
            "0.0300 ± 0.0000",
            "1.500",
            "1.500 – 1.500"
        ],
        "{md}"
    );
    assert!(md.contains("0.0300 (first of 2)"), "{md}");
}

#[test]
fn a_failing_command_stops_the_series_and_keeps_the_runs_before_it() {
    let dir = scratch("interleave-fail");
    let out = dir.join("ab");
    let (code, text, _) = xtask(&[
        "interleave",
        "--a",
        "echo '0.01 s/step'",
        "--b",
        "echo 'about to fail'; exit 5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(3), "a failed run exits 3: {text}");
    assert!(
        text.contains("run 2 (B, B)") && text.contains("run-2-B.log"),
        "the error names the run and its log: {text}"
    );
    let r = rows(&out);
    assert_eq!(r.len(), 1, "only run 1 completed: {r:?}");
    assert_eq!((r[0].0, r[0].1.as_str()), (1, "A"));
    let log = std::fs::read_to_string(out.join("run-2-B.log")).unwrap();
    assert!(log.contains("about to fail"), "{log}");

    let (code, text, _) = xtask(&[
        "interleave",
        "--a",
        "true",
        "--b",
        "true",
        "--label-a",
        "x/y",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("label \"x/y\""), "{text}");
    let (code, text, _) = xtask(&[
        "interleave",
        "--a",
        "true",
        "--b",
        "true",
        "--label-a",
        "same",
        "--label-b",
        "same",
    ]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("both \"same\""), "{text}");
}
