//! `validate --case X` runs X even when another scene in the directory is malformed (it is
//! reported as skipped), writes summary.json, and reads it back into its struct; a malformed
//! scene that is selected fails the run as bad input (exit 2) with the summary still written.
//! Also: a known failure declared in a scene is reported and does not fail the validation.

mod common;

use common::{run, scratch, xtask_command};
use std::path::Path;

const ELLIPSE: &str = include_str!("../../cases/prescribed_ellipse.toml");

fn validate(cases: &Path, case: &str, out: &Path) -> (Option<i32>, String) {
    let (code, text, _) = run(xtask_command()
        .args(["validate", "--case", case, "--cases"])
        .arg(cases)
        .arg("--out")
        .arg(out));
    (code, text)
}

#[test]
fn a_malformed_scene_that_is_not_selected_does_not_stop_the_others() {
    let dir = scratch("suite-select");
    std::fs::write(dir.join("prescribed_ellipse.toml"), ELLIPSE).unwrap();
    std::fs::write(dir.join("broken.toml"), "dim = \"two\"\n").unwrap();
    let (code, text) = validate(&dir, "prescribed_ellipse", &dir.join("out"));
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("skipped (not selected)"), "{text}");
    assert!(text.contains("read back: identical"), "{text}");
    // Selected, the malformed scene is bad input; the summary is still written.
    let (code, text) = validate(&dir, "broken", &dir.join("out2"));
    assert_eq!(code, Some(2), "{text}");
    assert!(dir.join("out2/summary.json").exists(), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_declared_known_failure_is_reported_but_does_not_fail_the_validation() {
    let dir = scratch("suite-known");
    // The Euler slope check passes; a scene check on the same run that cannot pass (reached_t
    // ≥ 1 for a run to t = 0.003) is declared a known failure.
    let scene = format!(
        "{ELLIPSE}\n[[check]]\nquantity = \"reached_t\"\nmin = 1.0\nknown_failure = \"the run is shorter than that\"\n"
    );
    std::fs::write(dir.join("prescribed_ellipse.toml"), &scene).unwrap();
    let (code, text) = validate(&dir, "prescribed_ellipse", &dir.join("out"));
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("known failure"), "{text}");
    let summary = std::fs::read_to_string(dir.join("out/summary.json")).unwrap();
    assert!(
        summary.contains("the run is shorter than that"),
        "{summary}"
    );
    // Without the declaration the same check fails the run.
    let plain = scene.replace("known_failure = \"the run is shorter than that\"\n", "");
    std::fs::write(dir.join("prescribed_ellipse.toml"), plain).unwrap();
    let (code, text) = validate(&dir, "prescribed_ellipse", &dir.join("out2"));
    assert_eq!(code, Some(1), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_scene_directory_without_scenes_is_bad_input() {
    let dir = scratch("suite-empty");
    std::fs::write(dir.join("notes.txt"), "no scenes here\n").unwrap();
    let (code, text, _) = run(xtask_command()
        .args(["validate", "--cases"])
        .arg(&dir)
        .arg("--out")
        .arg(dir.join("out")));
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("holds no scene"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

/// SIGINT during the second of two scenes: exit 130, the first scene's checks are in
/// summary.json (which says the validation did not pass), the interrupted run's record says
/// `interrupted`.
#[cfg(unix)]
#[test]
fn an_interrupted_validation_keeps_the_finished_scenes_summary() {
    let dir = scratch("suite-sigint");
    std::fs::write(dir.join("a_ellipse.toml"), ELLIPSE).unwrap();
    // A 20² cavity of 30 000 steps: long enough to be interrupted.
    let cavity = "case = \"lid_driven_cavity\"\ndim = 2\ndx = 0.05\nkernel = \"wendland_c2\"\ndt = 0.001\nt_end = 30.0\nschemes = [\"euler\"]\n[cavity]\nreynolds = 100\ncheck_ghia = false\n[effects]\nshifting = { coefficient = 2.0 }\n";
    std::fs::write(dir.join("b_cavity.toml"), cavity).unwrap();
    let out = dir.join("out");
    let mut child = xtask_command()
        .args(["validate", "--cases"])
        .arg(&dir)
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !out.join("b_cavity_euler.csv").exists() {
        assert!(
            t0.elapsed().as_secs() < 120,
            "the second scene never started"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "validation ended early"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(200));
    let killed = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["passed"], false);
    let checks = summary["checks"].as_array().unwrap();
    assert!(
        checks
            .iter()
            .any(|c| c["case"].as_str().unwrap().contains("a_ellipse")),
        "{summary}"
    );
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("b_cavity_euler.run.json")).unwrap())
            .unwrap();
    assert_eq!(record["status"], "interrupted");
    std::fs::remove_dir_all(&dir).ok();
}
