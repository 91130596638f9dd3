//! What `dgsph` writes, read back by independent code: ParaView files (with this crate's
//! reader here; `scripts/check_vtk.py` reads them with VTK/meshio in CI), the MCAP file, the
//! typed run records; and the exit codes.

mod common;
use common::*;

/// The paper's 2D drop posed as a flow scene (no built-in checks), without the flow scenes'
/// default hyperviscosity, whose step limit would bind here: these tests count steps of `dt`.
const DROP: &str = "dim = 2\ndx = 0.1\ndt = 2e-4\nt_end = 6e-4\nschemes = [\"euler\", \"dg\"]\n[[fluid]]\nshape = \"ellipse\"\ncenter = [0.0, 0.0]\nsemi_axes = [1.0, 0.7]\nlattice = \"centered\"\nvelocity_gradient = [[-100.0, 0.0], [0.0, 100.0]]\n[free_surface]\n[effects]\nhyperviscosity = { speed = 0.0 }\n[output]\ndiagnostics = [\"det_f\"]\n";

#[test]
fn paraview_files_hold_every_frame_point_and_field() {
    let dir = scratch("vtk");
    let s = scene(&dir, "d", DROP);
    let out = dir.join("o");
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--vtk",
        "--frame-every",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    for scheme in ["euler", "dg"] {
        let pvd = std::fs::read_to_string(out.join(format!("d_{scheme}.pvd"))).unwrap();
        let frames = dgsph::vtk::read_pvd(&pvd);
        // t = 0 and three steps, every record a frame (--frame-every 1).
        assert_eq!(
            frames.iter().map(|f| f.1).collect::<Vec<_>>(),
            [0, 1, 2, 3],
            "{pvd}"
        );
        let record: dgsph::summary::RunRecord = serde_json::from_str(
            &std::fs::read_to_string(out.join(format!("d_{scheme}.run.json"))).unwrap(),
        )
        .unwrap();
        for (t, _, file) in &frames {
            let data = dgsph::vtk::read_vtp(&std::fs::read(out.join(file)).unwrap()).unwrap();
            assert_eq!(data.points, record.fluid + record.walls);
            assert_eq!(data.positions.len(), data.points);
            let names: Vec<&str> = data.arrays.iter().map(|a| a.0.as_str()).collect();
            assert_eq!(names, dgsph::vtk::FIELDS);
            for (name, comps, values) in &data.arrays {
                assert_eq!(values.len(), comps * data.points, "{name}");
                assert!(values.iter().all(|v| v.is_finite()), "{name}");
            }
            // det F is 1 at t = 0 and a step's det F after (the diagnostic is on).
            let det = &data.arrays[3].2;
            if *t == 0.0 {
                assert!(det.iter().all(|d| *d == 1.0));
            } else {
                assert!(det.iter().any(|d| *d != 1.0));
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn mcap_and_run_record_read_back() {
    let dir = scratch("mcap");
    let s = scene(&dir, "d", DROP);
    let out = dir.join("o");
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--frame-every",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let bytes = std::fs::read(out.join("d_dg.mcap")).unwrap();
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("a finished file has a summary");
    let counts = &summary.stats.as_ref().unwrap().channel_message_counts;
    let topic = |t: &str| summary.channels.values().find(|c| c.topic == t).unwrap().id;
    assert_eq!(counts[&topic("/metrics")], 4);
    // Frames at records 0 and 2 of 4.
    assert_eq!(counts[&topic("/particles")], 2);
    let csv = std::fs::read_to_string(out.join("d_dg.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let last = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .filter(|m| m.channel.topic == "/metrics")
        .last()
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&last.data).unwrap();
    let keys: Vec<&str> = json
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    let mut sorted = header.clone();
    sorted.sort_unstable();
    let mut k = keys.clone();
    k.sort_unstable();
    assert_eq!(k, sorted, "MCAP metrics keys are the CSV columns");
    // The typed run record round-trips.
    let text_rec = std::fs::read_to_string(out.join("d_dg.run.json")).unwrap();
    let rec: dgsph::summary::RunRecord = serde_json::from_str(&text_rec).unwrap();
    assert_eq!(serde_json::to_string_pretty(&rec).unwrap(), text_rec);
    assert_eq!(
        (
            rec.scheme.as_str(),
            rec.kernel.as_str(),
            rec.status.as_str()
        ),
        ("dg", "quintic_spline", "completed")
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `--sample-every N` sets the steps between records: every N-th step and the last, read from
/// the CSV's step column (the drop scene records every step otherwise).
#[test]
fn sample_every_flag_sets_the_recorded_steps() {
    let dir = scratch("sample-every");
    let s = scene(&dir, "d", &DROP.replace("t_end = 6e-4", "t_end = 1e-3"));
    for (flag, steps) in [
        (None, vec![0, 1, 2, 3, 4, 5]),
        (Some("2"), vec![0, 2, 4, 5]),
        (Some("5"), vec![0, 5]),
    ] {
        let out = dir.join(format!("o{}", flag.unwrap_or("-")));
        let mut args = vec!["run", s.to_str().unwrap(), "--out", out.to_str().unwrap()];
        if let Some(n) = flag {
            args.extend(["--sample-every", n]);
        }
        let o = dgsph(&args);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        let csv = std::fs::read_to_string(out.join("d_dg.csv")).unwrap();
        let mut lines = csv.lines();
        assert!(lines.next().unwrap().starts_with("step,"), "{csv}");
        let got: Vec<u64> = lines
            .map(|l| l.split(',').next().unwrap().parse().unwrap())
            .collect();
        assert_eq!(got, steps, "--sample-every {flag:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn exit_codes_tell_bad_input_failed_checks_and_failed_runs_apart() {
    let dir = scratch("exit");
    // Bad input: 2.
    let bad = scene(&dir, "bad", &DROP.replace("dx = 0.1", "dx = -1"));
    let o = dgsph(&[
        "run",
        bad.to_str().unwrap(),
        "--out",
        dir.join("o").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("`dx`"), "{}", text(&o));
    // A check that fails: 1 (the drop's speed is 100, the scene asks for at most 1).
    let check = scene(
        &dir,
        "check",
        &format!("{DROP}[[check]]\nquantity = \"max_speed\"\nmax = 1.0\n"),
    );
    let o = dgsph(&[
        "run",
        check.to_str().unwrap(),
        "--out",
        dir.join("o").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    // A step that blows up: 3 (Δt 100× the drop's, taken as it is: the automatic step would
    // have kept it within the advective limit).
    let blow = scene(
        &dir,
        "blow",
        &format!(
            "{}[time_step]\nauto = false\n",
            DROP.replace("dt = 2e-4", "dt = 2e-2")
                .replace("t_end = 6e-4", "t_end = 0.06")
        ),
    );
    let o = dgsph(&[
        "run",
        blow.to_str().unwrap(),
        "--out",
        dir.join("o").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("blow-up"), "{}", text(&o));
    // The records up to the failure are kept and readable.
    let csv = std::fs::read_to_string(dir.join("o/blow_euler.csv")).unwrap();
    assert!(csv.lines().count() >= 2);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn check_prints_counts_memory_and_steps_without_running() {
    let dir = scratch("check");
    let s = scene(&dir, "d", DROP);
    let o = dgsph(&["check", s.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("particles   219 fluid + 0 wall = 219"), "{t}");
    assert!(
        t.contains("memory") && t.contains("steps       3 of dt"),
        "{t}"
    );
    let o = dgsph(&["--version"]);
    assert!(text(&o).contains(env!("CARGO_PKG_VERSION")));
    std::fs::remove_dir_all(&dir).ok();
}

/// The cavity's tables as CSV files, parsed here: the centreline profile (17 Ghia points, the
/// lid's Ghia value 1 at y = 1) and the end-of-run density field (one row per probe of the
/// 10 × 10 probe array, inside the cavity, finite errors).
#[test]
fn cavity_tables_read_back_as_csv() {
    let dir = scratch("tables");
    // No snapshot: only the end-of-run field.
    let s = scene(&dir, "c", &cavity(0.02).replace("snapshots = [0.05]\n", ""));
    let out = dir.join("o");
    let o = dgsph(&["run", s.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let parse = |file: &str| -> (String, Vec<Vec<f64>>) {
        let t = std::fs::read_to_string(out.join(file)).unwrap();
        let mut lines = t.lines();
        let header = lines.next().unwrap().to_string();
        let rows = lines
            .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
            .collect();
        (header, rows)
    };
    let (header, rows) = parse("c_dg_u_profile.csv");
    assert_eq!(header, "y,u,u_ghia");
    assert_eq!(rows.len(), 17, "Ghia et al.'s u(0.5, y) points");
    assert!(rows.iter().all(|r| r.len() == 3 && r[1].is_finite()));
    let top = rows.iter().find(|r| r[0] == 1.0).expect("the lid's row");
    assert_eq!(top[2], 1.0);
    let (header, rows) = parse("c_dg_density_t0.020.csv");
    assert_eq!(header, "x,y,z,density_error");
    assert_eq!(rows.len(), 100, "one row per probe");
    for r in &rows {
        assert_eq!(r.len(), 4);
        assert!(
            r[0] > 0.0 && r[0] < 1.0 && r[1] > 0.0 && r[1] < 1.0 && r[2] == 0.0,
            "{r:?}"
        );
        assert!(r[3].is_finite() && r[3].abs() < 0.5, "{r:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
