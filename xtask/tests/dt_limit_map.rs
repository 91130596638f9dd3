//! `cargo xtask dt-limit --scene … --end … --dx …` (a stability map) through the real binary: the
//! coarse dam break at two spacings, every scheme, about 20 seconds. The CSV, the Markdown table
//! and the figure are written; each search brackets a limit (a stable Δt below an unstable
//! one, within the bisection's 1/32); a search that never meets an unstable step reports the
//! five-step cap itself; a bad `--dx` or `--end` is bad input (exit 2) naming the flag.

mod common;

use common::{scratch, xtask};
use std::path::Path;

fn scene(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(rel)
        .to_str()
        .unwrap()
        .to_string()
}

/// The CSV's rows as (scene, dx, scheme, dt_stable, dt_unstable, reason).
fn rows(csv: &str) -> Vec<(String, f64, String, f64, f64, String)> {
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("scene,dx,scheme,dt_stable,cfl_stable,dt_unstable,cfl_unstable,reason")
    );
    lines
        .map(|l| {
            let (head, reason) = l.split_once(",\"").expect("a quoted reason");
            let c: Vec<&str> = head.split(',').collect();
            assert_eq!(c.len(), 7, "{l}");
            (
                c[0].to_string(),
                c[1].parse().unwrap(),
                c[2].to_string(),
                c[3].parse().unwrap(),
                c[5].parse().unwrap(),
                reason.trim_end_matches('"').to_string(),
            )
        })
        .collect()
}

#[test]
fn a_stability_map_brackets_each_schemes_limit_at_each_spacing() {
    let out = scratch("dt-limit-map");
    let (code, text, _) = xtask(&[
        "dt-limit",
        "--scene",
        &scene("cases/hard/dam_break.toml"),
        // To t = 1: at dx = 0.1 the Euler and PC runs to t = 0.5 are stable up to the five-step
        // cap (0.1) with the surface band's completed rows.
        "--end",
        "1.0",
        "--dx",
        "0.1,0.0625",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    let csv = std::fs::read_to_string(out.join("dt_limit.csv")).unwrap();
    let rows = rows(&csv);
    let md = std::fs::read_to_string(out.join("dt_limit.md")).unwrap();
    assert_eq!(rows.len(), 6, "two spacings × three schemes: {csv}");
    for (dx, scheme) in [0.1, 0.0625]
        .iter()
        .flat_map(|dx| ["euler", "predictor_corrector", "dg"].map(|s| (*dx, s)))
    {
        let r = rows
            .iter()
            .find(|r| r.1 == dx && r.2 == scheme)
            .unwrap_or_else(|| panic!("no row for {scheme} at dx {dx}: {csv}"));
        assert_eq!(r.0, "dam_break");
        // A dam break at this Δt range blows up: every search found an unstable step, with
        // its reason, and brackets the limit within 1/32 of it.
        assert!(
            r.3 > 0.0 && r.4 > r.3 && r.4 - r.3 <= r.4 / 32.0 + 1e-12,
            "{r:?}"
        );
        assert!(!r.5.is_empty(), "{r:?}");
        // The table has the same row.
        let line = format!("| dam_break | {dx} |");
        assert!(
            md.lines()
                .any(|l| l.starts_with(&line) && l.contains(&format!("| {scheme} | {:.3e} |", r.3))),
            "{md}"
        );
    }
    let svg = std::fs::read_to_string(out.join("dt_limit.svg")).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("dam_break euler"),
        "{svg}"
    );
}

#[test]
fn a_search_that_meets_no_unstable_step_reports_the_cap() {
    let out = scratch("dt-limit-cap");
    // Five steps of the elliptical drop are stable at any Δt this search tries.
    let (code, text, _) = xtask(&[
        "dt-limit",
        "--scene",
        &scene("cases/elliptical_drop.toml"),
        "--end",
        "0.002",
        "--dx",
        "0.04",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    let rows = rows(&std::fs::read_to_string(out.join("dt_limit.csv")).unwrap());
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert_eq!(r.3, 0.002 / 5.0, "the cap T/5 itself was tried: {r:?}");
        assert!(r.4.is_nan(), "{r:?}");
        assert!(r.5.contains("five-step cap"), "{r:?}");
    }
}

#[test]
fn a_bad_spacing_or_end_is_bad_input_naming_the_field() {
    let path = scene("cases/hard/dam_break.toml");
    for (dx, end, field) in [
        ("--dx=-0.1", "0.5", "`dx` must be"),
        ("--dx=0.1", "0", "`t_end` must be"),
    ] {
        let out = scratch("dt-limit-bad");
        let (code, text, _) = xtask(&[
            "dt-limit",
            "--scene",
            &path,
            dx,
            "--end",
            end,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, Some(2), "{dx} --end {end}: {text}");
        assert!(text.contains(field), "{dx} --end {end}: {text}");
        assert!(
            !out.join("dt_limit.csv").exists(),
            "nothing written: {text}"
        );
    }
}
