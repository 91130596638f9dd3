//! A deliberately broken reference makes `cargo xtask validate` fail, naming the check; a
//! malformed reference is an error naming the file and line. Runs the real binary on the
//! prescribed-ellipse case (a fraction of a second) with `--references DIR`.

mod common;

use common::{run, scratch, xtask_command};
use std::path::Path;

const SLOPES: &str = include_str!("../../cases/reference/volume_slopes.csv");

fn validate(refs: &Path, out: &Path) -> (Option<i32>, String) {
    let cases = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases");
    let (code, text, _) = run(xtask_command()
        .args(["validate", "--case", "prescribed_ellipse", "--cases"])
        .arg(&cases)
        .arg("--references")
        .arg(refs)
        .arg("--out")
        .arg(out));
    (code, text)
}

/// The 2D Euler row at Δt = 1.25e-4 with its predicted slope replaced by `value`.
fn with_slope(value: &str) -> String {
    let row = "2d_sec3,u=-100x;v=+100y,euler,1.25e-4,-1.250097666,";
    assert!(SLOPES.contains(row), "reference row moved");
    SLOPES.replace(
        row,
        &format!("2d_sec3,u=-100x;v=+100y,euler,1.25e-4,{value},"),
    )
}

#[test]
fn intact_references_pass() {
    let dir = scratch("refs-intact");
    std::fs::write(dir.join("volume_slopes.csv"), SLOPES).unwrap();
    let (code, text) = validate(&dir, &dir.join("out"));
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("volume_slopes.csv from"), "{text}");
}

#[test]
fn perturbed_reference_fails_the_run_naming_the_check() {
    let dir = scratch("refs-perturbed");
    // A 1e-6 relative change: far below what a plot would show, far above the check's 1e-8.
    std::fs::write(dir.join("volume_slopes.csv"), with_slope("-1.250098916")).unwrap();
    let (code, text) = validate(&dir, &dir.join("out"));
    assert_eq!(code, Some(1), "{text}");
    let failing: Vec<&str> = text.lines().filter(|l| l.ends_with("FAIL")).collect();
    assert_eq!(failing.len(), 1, "{text}");
    assert!(
        failing[0].contains("euler 2D exact slope vs table"),
        "{text}"
    );
    assert!(text.contains("1 failed"), "{text}");
    let summary = std::fs::read_to_string(dir.join("out/summary.json")).unwrap();
    assert!(summary.contains("\"passed\": false"), "{summary}");
}

#[test]
fn malformed_reference_is_an_error_naming_file_and_line() {
    let dir = scratch("refs-malformed");
    std::fs::write(dir.join("volume_slopes.csv"), with_slope("-1.25O")).unwrap();
    let (code, text) = validate(&dir, &dir.join("out"));
    assert_eq!(code, Some(2), "{text}");
    assert!(
        text.contains("volume_slopes.csv, line 2") && text.contains("not a number"),
        "{text}"
    );
}
