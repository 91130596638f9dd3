//! `cargo xtask validate --sweep --study dt` through the real binary (the elliptical drop at
//! four time steps and three schemes, a few seconds): `sweep.csv` and `sweep.md` are written
//! whole, agree with each other row for row, and no temporary file is left beside them; a
//! missing scene is bad input (exit 2) naming it, not a failure to write results.

mod common;

use common::{scratch, xtask};
use std::path::Path;

/// `xtask validate --sweep --study dt` on the scenes in `cases`, into `out`: exit code and
/// output.
fn dt_sweep(cases: &Path, out: &Path) -> (Option<i32>, String) {
    let (code, text, _) = xtask(&[
        "validate",
        "--sweep",
        "--study",
        "dt",
        "--cases",
        cases.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    (code, text)
}

#[test]
fn the_dt_sweep_writes_a_csv_and_a_table_that_agree() {
    let out = scratch("sweep-dt");
    let (code, text) = dt_sweep(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases"),
        &out,
    );
    assert_eq!(code, Some(0), "{text}");

    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (scheme, dt, error, pareto, status) = (
        col("scheme"),
        col("dt"),
        col("error"),
        col("pareto"),
        col("status"),
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(!rows.is_empty(), "{csv}");
    for r in &rows {
        assert_eq!(r.len(), header.len(), "{r:?}");
        assert_eq!(r[col("study")], "dt", "{r:?}");
    }
    let steps: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[dt]).collect();
    assert!(
        steps.len() >= 3,
        "a dt study runs several time steps: {steps:?}"
    );

    // Each CSV row appears in the Markdown table with the same scheme, error (to the table's
    // three digits), Pareto mark and status.
    let md = std::fs::read_to_string(out.join("sweep.md")).unwrap();
    let table: Vec<Vec<String>> = md
        .lines()
        .filter(|l| l.starts_with("| ") && l.contains(" | dt | "))
        .map(|l| {
            l.split(" | ")
                .map(|c| c.trim_matches('|').trim().to_string())
                .collect()
        })
        .collect();
    assert_eq!(table.len(), rows.len(), "{md}");
    for (r, t) in rows.iter().zip(&table) {
        assert_eq!(t[2], r[scheme], "{t:?} against {r:?}");
        let e: f64 = r[error].parse().unwrap();
        assert_eq!(t[11], format!("{e:.3e}"), "{t:?} against {r:?}");
        assert_eq!(t[0] == "★", r[pareto] == "true", "{t:?} against {r:?}");
        assert_eq!(t[13] == "ok", r[status] == "ok", "{t:?} against {r:?}");
    }

    let leftovers: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn a_missing_sweep_scene_is_bad_input_naming_it() {
    let dir = scratch("sweep-missing");
    let (code, text) = dt_sweep(&dir, &dir.join("out"));
    assert_eq!(code, Some(2), "a missing scene is bad input: {text}");
    assert!(text.contains("elliptical_drop.toml"), "{text}");
    assert!(!text.contains("writing results"), "{text}");
    assert!(
        !dir.join("out").exists(),
        "nothing is created before the input is read"
    );
}
