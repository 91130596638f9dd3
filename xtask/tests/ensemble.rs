//! `cargo xtask ensemble` through the real binary: each draw is the run `xtask run` (= `dgsph
//! run`) gives at that draw's time step, bit for bit; the Markdown statistics are those of the
//! CSV's values (recomputed here from the file); bad flags are typed input errors (exit 2).
//! The 20² Re 100 cavity to t = 0.3 (30 steps of DG, a fraction of a second per draw).

mod common;

use common::{scratch, xtask};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/cavity_re100.toml")
}

/// CSV rows `scheme,draw,dt,status,result,value`, as (draw, dt, result) → value.
fn read_csv(path: &Path) -> BTreeMap<(usize, String), (f64, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("scheme,draw,dt,status,result,value"));
    let mut rows = BTreeMap::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 6, "{line}");
        assert_eq!((f[0], f[3]), ("dg", "completed"), "{line}");
        let dt: f64 = f[2].parse().unwrap();
        let v: f64 = f[5].parse().unwrap();
        rows.insert((f[1].parse().unwrap(), f[4].to_string()), (dt, v));
    }
    rows
}

/// A completed run's `run.json` results (timings aside) are draw `k`'s values (`drawn(key)`),
/// bit for bit (NaN for NaN), at least ten of them.
fn assert_results_are_the_draws(run_json: &Path, k: usize, drawn: impl Fn(&str) -> f64) {
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run_json).unwrap()).unwrap();
    assert_eq!(json["status"], "completed", "{json}");
    let results = json["results"].as_object().unwrap();
    let mut compared = 0;
    for (key, v) in results {
        if key.contains("seconds") {
            continue;
        }
        let Some(v) = v.as_f64() else { continue };
        let d = drawn(key);
        assert!(
            d == v || (d.is_nan() && v.is_nan()),
            "draw {k}, {key}: {d} against {v}"
        );
        compared += 1;
    }
    assert!(compared >= 10, "only {compared} results compared");
}

#[test]
fn draws_are_the_runs_at_their_time_steps_and_the_table_their_statistics() {
    let dir = scratch("ensemble");
    let out = dir.join("ens");
    let scene = scene();
    let scene = scene.to_str().unwrap();
    let (code, text, _) = xtask(&[
        "ensemble",
        scene,
        "--draws",
        "3",
        "--perturbation",
        "1e-13",
        "--t-end",
        "0.3",
        "--schemes",
        "dg",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    let rows = read_csv(&out.join("cavity_re100_ensemble.csv"));
    let dts: Vec<f64> = (0..3).map(|k| rows[&(k, "ghia_v_rms".into())].0).collect();
    // The scene's Δt is 0.01; draw k runs at 0.01 (1 − k 1e-13).
    assert_eq!(dts[0], 0.01);
    for (k, dt) in dts.iter().enumerate() {
        assert_eq!(*dt, 0.01 * (1.0 - k as f64 * 1e-13), "draw {k}");
    }
    // Each draw is `xtask run` at its time step: every result bit for bit (wall times aside).
    for (k, dt) in dts.iter().enumerate() {
        let run_out = dir.join(format!("run{k}"));
        let (code, text, _) = xtask(&[
            "run",
            scene,
            "--t-end",
            "0.3",
            "--schemes",
            "dg",
            "--dt",
            &format!("{dt:?}"),
            "--progress-every",
            "0",
            "--out",
            run_out.to_str().unwrap(),
        ]);
        // Exit 1: the scene's Ghia checks fail at t = 0.3, far from the steady state (the
        // ensemble reports values, not checks).
        assert_eq!(code, Some(1), "{text}");
        assert_results_are_the_draws(&run_out.join("cavity_re100_dg.run.json"), k, |key| {
            rows[&(k, key.to_string())].1
        });
    }
    // The draws differ (round-off grows over 30 steps into the last digits of the deviations).
    let v: Vec<f64> = (0..3).map(|k| rows[&(k, "ghia_v_rms".into())].1).collect();
    assert!(v[0] != v[1] && v[1] != v[2], "{v:?}");
    // The Markdown row is the statistics of the CSV's values.
    let mean = v.iter().sum::<f64>() / 3.0;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 2.0).sqrt();
    let se = sd / 3f64.sqrt();
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let md = std::fs::read_to_string(out.join("cavity_re100_ensemble.md")).unwrap();
    let row = md
        .lines()
        .find(|l| l.starts_with("| ghia_v_rms |"))
        .unwrap_or_else(|| panic!("{md}"));
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    assert_eq!(cells[2], "3", "{row}");
    let close = |cell: &str, x: f64, digits: f64| {
        let y: f64 = cell.parse().unwrap();
        assert!(
            (y - x).abs() <= x.abs() * digits,
            "{row}: {cell} against {x:e}"
        );
    };
    close(cells[3], mean, 1e-6);
    close(cells[4], sd, 1e-3);
    close(cells[5], se, 1e-3);
    close(cells[6], min, 1e-6);
    close(cells[7], max, 1e-6);
    assert!(md.contains("3 of 3 draws completed"), "{md}");
    // The summary says what ran: the overrides are part of the scene it records.
    assert!(
        md.contains("full preset, command-line overrides applied): 2D, dx = 0.05, t_end = 0.3,"),
        "{md}"
    );
    // ensemble-compare reads the file as written: against itself, every result differs by 0.
    let csv = out.join("cavity_re100_ensemble.csv");
    let cmp = dir.join("self.md");
    let (code, text, _) = xtask(&[
        "ensemble-compare",
        csv.to_str().unwrap(),
        csv.to_str().unwrap(),
        "--out",
        cmp.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    let cmp = std::fs::read_to_string(cmp).unwrap();
    let row = compare_row(&cmp, "dg", "ghia_v_rms");
    assert_eq!((row[3].as_str(), row[5].as_str()), ("3", "3"), "{row:?}");
    assert_eq!(
        row[4].parse::<f64>().unwrap(),
        row[6].parse::<f64>().unwrap()
    );
    assert_eq!(row[9], "+0.00", "{row:?}");
}

#[test]
fn bad_flags_are_input_errors_naming_the_flag() {
    let scene = scene();
    let scene = scene.to_str().unwrap();
    for (flags, says) in [
        (vec!["--perturbation", "0"], "--perturbation"),
        (vec!["--perturbation", "nan"], "--perturbation"),
        (vec!["--draws", "11", "--perturbation", "1e-6"], "--draws"),
        (vec!["--dt", "-1"], "dt"),
    ] {
        let mut args = vec!["ensemble", scene, "--out", "/nonexistent/never-written"];
        args.extend(flags.iter().copied());
        let (code, text, _) = xtask(&args);
        assert_eq!(code, Some(2), "{flags:?}: {text}");
        assert!(text.contains(says), "{flags:?}: {text}");
    }
    // clap's own range check: at least two draws.
    let (code, text, _) = xtask(&["ensemble", scene, "--draws", "1"]);
    assert_eq!(code, Some(2), "{text}");
    assert!(text.contains("--draws"), "{text}");
}

/// A Markdown table row of `ensemble-compare`'s output, by scheme and result, as cells.
fn compare_row(md: &str, scheme: &str, result: &str) -> Vec<String> {
    let row = md
        .lines()
        .find(|l| l.starts_with(&format!("| {scheme} | {result} |")))
        .unwrap_or_else(|| panic!("no row {scheme}/{result} in\n{md}"));
    row.split('|').map(|c| c.trim().to_string()).collect()
}

#[test]
fn compare_gives_the_difference_of_means_in_standard_errors() {
    let dir = scratch("ensemble-compare");
    let base = dir.join("base_ensemble.csv");
    let other = dir.join("other_ensemble.csv");
    // base: dg/a = 1, 2, 3 (and a failed draw, left out); dg/b = 10, 14; euler/a only here.
    std::fs::write(
        &base,
        "scheme,draw,dt,status,result,value\n\
         dg,0,0.01,completed,a,1.0\ndg,0,0.01,completed,b,10.0\n\
         dg,1,0.01,completed,a,2.0\ndg,1,0.01,completed,b,14.0\n\
         dg,2,0.01,completed,a,3.0\n\
         dg,3,0.01,failed,a,1e9\n\
         euler,0,0.01,completed,a,5.0\n",
    )
    .unwrap();
    // other: dg/a = 2, 3, 4; dg/b one draw, 18.
    std::fs::write(
        &other,
        "scheme,draw,dt,status,result,value\n\
         dg,0,0.01,completed,a,2.0\ndg,1,0.01,completed,a,3.0\ndg,2,0.01,completed,a,4.0\n\
         dg,0,0.01,completed,b,18.0\n",
    )
    .unwrap();
    let out = dir.join("cmp.md");
    let (code, text, _) = xtask(&[
        "ensemble-compare",
        base.to_str().unwrap(),
        other.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{text}");
    let md = std::fs::read_to_string(&out).unwrap();
    // dg/a: means 2 and 3 over 3 draws each (SD 1): z = 1 / √(2/3).
    let a = compare_row(&md, "dg", "a");
    assert_eq!((a[3].as_str(), a[5].as_str()), ("3", "3"), "{a:?}");
    assert_eq!(a[4].parse::<f64>().unwrap(), 2.0);
    assert_eq!(a[6].parse::<f64>().unwrap(), 3.0);
    assert_eq!(a[7].parse::<f64>().unwrap(), 1.0);
    assert_eq!(a[8], "+50.0 %");
    assert_eq!(a[9], format!("{:+.2}", 1.0 / (2.0f64 / 3.0).sqrt()));
    // dg/b: a single draw (18) against 10, 14 (mean 12, SD √8): z = 6 / (√8 √1.5).
    let b = compare_row(&md, "dg", "b");
    assert_eq!((b[3].as_str(), b[5].as_str()), ("2", "1"), "{b:?}");
    assert_eq!(
        b[9],
        format!("{:+.2}", 6.0 / (8.0f64.sqrt() * 1.5f64.sqrt()))
    );
    // euler/a is in one file only: not compared.
    assert!(!md.contains("| euler |"), "{md}");
    assert!(
        text.contains("| dg | a |"),
        "the table is printed too: {text}"
    );

    // Bad inputs: exit 2 naming the file (and line).
    let bad = dir.join("bad_ensemble.csv");
    std::fs::write(
        &bad,
        "scheme,draw,dt,status,result,value\ndg,0,0.01,completed,a,x\n",
    )
    .unwrap();
    let unrelated = dir.join("unrelated_ensemble.csv");
    std::fs::write(
        &unrelated,
        "scheme,draw,dt,status,result,value\npc,0,0.01,completed,z,1\n",
    )
    .unwrap();
    let missing = dir.join("missing.csv");
    for (b, o, says) in [
        (&bad, &other, format!("{}:2", bad.display())),
        (&base, &missing, missing.display().to_string()),
        (&base, &unrelated, "share no".to_string()),
        (&out, &other, format!("{}:1", out.display())),
    ] {
        let (code, text, _) = xtask(&[
            "ensemble-compare",
            b.to_str().unwrap(),
            o.to_str().unwrap(),
            "--out",
            dir.join("never.md").to_str().unwrap(),
        ]);
        assert_eq!(code, Some(2), "{text}");
        assert!(text.contains(&says), "{says}: {text}");
    }
    assert!(!dir.join("never.md").exists());
}

/// `--perturb gravity`: draw k runs with the gravity vector g (1 − k ε) and the scene's own
/// automatic step — each draw is `xtask run` of the scene with that gravity written into it, bit
/// for bit, and its steps were chosen from the state (its smallest step below the scene's bound).
/// The quick drop on a wall with its step bound raised to 0.01 (the advective limit binds once
/// the drop falls faster than 0.5 m/s), to t = 0.15, Euler.
#[test]
fn gravity_draws_keep_the_automatic_step() {
    let dir = scratch("ensemble-gravity");
    let out = dir.join("ens");
    let drop = Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/hard/drop_on_wall.toml");
    let text = std::fs::read_to_string(&drop).unwrap();
    let flags = [
        "--preset",
        "quick",
        "--dt",
        "0.01",
        "--t-end",
        "0.15",
        "--schemes",
        "euler",
    ];
    let mut args = vec![
        "ensemble",
        drop.to_str().unwrap(),
        "--draws",
        "3",
        "--perturbation",
        "1e-13",
        "--perturb",
        "gravity",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(flags);
    let (code, text_out, _) = xtask(&args);
    assert_eq!(code, Some(0), "{text_out}");
    let csv = std::fs::read_to_string(out.join("drop_on_wall_ensemble.csv")).unwrap();
    let mut rows: BTreeMap<(usize, String), f64> = BTreeMap::new();
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!((f[0], f[2], f[3]), ("euler", "0.01", "completed"), "{line}");
        rows.insert(
            (f[1].parse().unwrap(), f[4].to_string()),
            f[5].parse().unwrap(),
        );
    }
    let md = std::fs::read_to_string(out.join("drop_on_wall_ensemble.md")).unwrap();
    assert!(
        md.contains("g = [0.0, -9.81, 0.0] (Δt as the scene's, automatic, at most 0.01)"),
        "{md}"
    );
    for k in 0..3usize {
        let dt_min = rows[&(k, "dt_min".to_string())];
        assert!(
            dt_min > 0.0 && dt_min < 0.01,
            "draw {k}: smallest step {dt_min}"
        );
        // The same scene with the drawn gravity written into it, run by `xtask run`.
        let g = -9.81 * (1.0 - k as f64 * 1e-13);
        let copy = dir.join(format!("drop_on_wall_g{k}.toml"));
        std::fs::write(
            &copy,
            text.replace(
                "gravity = [0.0, -9.81, 0.0]",
                &format!("gravity = [0.0, {g:?}, 0.0]"),
            ),
        )
        .unwrap();
        let run_out = dir.join(format!("run{k}"));
        let mut run_args = vec![
            "run",
            copy.to_str().unwrap(),
            "--progress-every",
            "0",
            "--out",
            run_out.to_str().unwrap(),
        ];
        run_args.extend(flags);
        let (code, text_run, _) = xtask(&run_args);
        assert_eq!(code, Some(0), "{text_run}");
        assert_results_are_the_draws(
            &run_out.join(format!("drop_on_wall_g{k}_euler.run.json")),
            k,
            |key| rows[&(k, key.to_string())],
        );
    }
    // A scene without gravity has nothing to perturb: an input error naming the flag.
    let (code, text_bad, _) = xtask(&[
        "ensemble",
        scene().to_str().unwrap(),
        "--perturb",
        "gravity",
        "--out",
        "/nonexistent/never-written",
    ]);
    assert_eq!(code, Some(2), "{text_bad}");
    assert!(text_bad.contains("--perturb gravity"), "{text_bad}");
}
