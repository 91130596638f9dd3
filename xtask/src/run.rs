//! Running one scene: time series to CSV, checks against the references.

use crate::flags::Preset;
use anyhow::Context;
use sph_cases::drop::{self, DropRecord};
use sph_cases::{CaseKind, Check, Scene, prescribed};
use sph_core::{D2, D3, Dim};
use sph_integrators::SchemeKind;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Reads and validates a scene file.
pub fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading scene {}", path.display()))?;
    Ok(Scene::parse(&path.display().to_string(), &text)?)
}

/// Applies the command-line overrides of `cargo xtask run` and re-validates the scene.
pub fn apply_overrides(mut scene: Scene, args: &crate::flags::RunArgs) -> anyhow::Result<Scene> {
    if let Some(dx) = args.dx {
        scene.dx = dx;
    }
    if let Some(dt) = args.dt {
        scene.dt = dt;
    }
    if let Some(t) = args.t_end {
        scene.t_end = t;
    }
    if let Some(th) = args.div_r_threshold {
        scene.free_surface = Some(sph_integrators::FreeSurface {
            div_r_threshold: th,
        });
    }
    if let Some(h) = &args.dg_hessian {
        scene.dg_hessian = match h.as_str() {
            "eq25" => sph_cases::DgHessianChoice::Eq25,
            "quadratic_fit" => sph_cases::DgHessianChoice::QuadraticFit,
            other => anyhow::bail!("--dg-hessian must be eq25 or quadratic_fit, got {other:?}"),
        };
    }
    scene.validate("command-line overrides")?;
    Ok(scene)
}

/// One scheme's run, for `summary.json`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RunInfo {
    /// Case name.
    pub case: String,
    /// Scheme (or position update) name.
    pub scheme: String,
    /// Kernel.
    pub kernel: String,
    /// Dimension.
    pub dim: usize,
    /// Number of particles.
    pub particles: usize,
    /// Number of steps (including a short last step).
    pub steps: usize,
    /// Wall time of the run in seconds.
    pub wall_s: f64,
    /// Mean pressure-solver iterations per step (0 for prescribed-field runs).
    pub solver_iters_mean: f64,
}

/// Checks and runs of one scene.
#[derive(Default)]
pub struct SceneResult {
    /// Pass/fail checks.
    pub checks: Vec<Check>,
    /// One entry per scheme run.
    pub runs: Vec<RunInfo>,
}

/// Runs `scene` (with the preset applied), writing `<out>/<case>_<scheme>.csv` per scheme, and
/// returns its checks.
pub fn run_scene(scene: &Scene, preset: Preset, out: &Path) -> anyhow::Result<SceneResult> {
    let scene = match preset {
        Preset::Quick => scene.quick(),
        Preset::Paper => scene.clone(),
    };
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    match scene.case {
        CaseKind::EllipticalDrop => run_drop::<D2>(&scene, out),
        CaseKind::SpheroidDrop => run_drop::<D3>(&scene, out),
        CaseKind::PrescribedEllipse => run_prescribed::<D2>(&scene, out),
        CaseKind::PrescribedEllipsoid => run_prescribed::<D3>(&scene, out),
    }
}

fn csv_path(out: &Path, scene: &Scene, scheme: &str) -> PathBuf {
    out.join(format!("{}_{}.csv", scene.case.name(), scheme))
}

const DROP_HEADER: &str = "scheme,step,t,short_step,measure_moments,measure_hull,rel_change_moments,rel_change_hull,a,b,a_exact,b_exact,p_centre,p_centre_exact,iterations,rel_residual,max_div_u,det_f_min,det_f_mean,det_f_max,free_surface_particles,step_seconds";

fn drop_row(r: &DropRecord, first: &DropRecord) -> String {
    let rep = r.report.unwrap_or_default();
    let det = rep.det_f.unwrap_or_default();
    format!(
        "{},{},{:.9e},{},{:.12e},{:.12e},{:.6e},{:.6e},{:.9e},{:.9e},{:.9e},{:.9e},{:.6e},{:.6e},{},{:.3e},{:.6e},{:.9e},{:.9e},{:.9e},{},{:.6e}",
        r.scheme.name(),
        r.step,
        r.t,
        r.short_step,
        r.measure_moments,
        r.measure_hull,
        r.measure_moments / first.measure_moments - 1.0,
        r.measure_hull / first.measure_hull - 1.0,
        r.semi_axes[0],
        r.semi_axes[1],
        r.exact.a,
        r.exact.b,
        r.p_centre,
        r.exact.p_c,
        rep.solve.iterations,
        rep.solve.rel_residual,
        rep.max_div_u,
        det.min,
        det.mean,
        det.max,
        rep.free_surface_particles,
        rep.seconds,
    )
}

fn run_drop<D: Dim>(scene: &Scene, out: &Path) -> anyhow::Result<SceneResult> {
    let case = scene.case.name();
    let mut checks = Vec::new();
    let mut runs = Vec::new();
    let mut infos = Vec::new();
    let n_particles = drop::setup::<D>(scene).particles.len();
    for &scheme in &scene.schemes {
        let path = csv_path(out, scene, scheme.name());
        let file =
            std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
        let mut w = std::io::BufWriter::new(file);
        writeln!(w, "{DROP_HEADER}")?;
        let mut first: Option<DropRecord> = None;
        let t0 = std::time::Instant::now();
        let mcap_path = out.join(format!("{}-{}.mcap", case, scheme.name()));
        let mut meta = std::collections::BTreeMap::new();
        meta.insert("case".into(), case.to_string());
        meta.insert("scheme".into(), scheme.name().to_string());
        meta.insert("dim".into(), D::DIM.to_string());
        meta.insert("scene".into(), serde_json::to_string(scene)?);
        let mut sink = crate::mcap_sink::McapSink::create(&mcap_path, 1, meta)?;
        // Each row is flushed as it is produced: a failing step loses nothing already computed,
        // and the MCAP file is finished on every path (explicitly below, or on drop).
        let records = drop::run::<D>(scene, scheme, &mut |r, frame| {
            let f = first.get_or_insert_with(|| r.clone());
            let row = drop_row(r, f);
            let metrics: serde_json::Map<String, serde_json::Value> = DROP_HEADER
                .split(',')
                .zip(row.split(','))
                .map(|(k, v)| {
                    (
                        k.to_string(),
                        v.parse::<f64>().map_or_else(|_| v.into(), |x| x.into()),
                    )
                })
                .collect();
            sink.frame(frame, &serde_json::Value::Object(metrics));
            writeln!(w, "{row}")?;
            w.flush()
        });
        sink.finish()?;
        let records = match records {
            Ok(r) => r,
            Err(e) => {
                eprintln!(
                    "  {case} {}: FAILED: {e} (rows so far in {})",
                    scheme.name(),
                    path.display()
                );
                checks.push(Check::new(
                    case,
                    format!("{} run completes", scheme.name()),
                    0.0,
                    1.0,
                    0.0,
                    e.to_string(),
                ));
                continue;
            }
        };
        let last = drop::last_full_step(&records);
        let steps = records.len() - 1;
        let mean_step: f64 = records
            .iter()
            .filter_map(|r| r.report.map(|x| x.seconds))
            .sum::<f64>()
            / steps.max(1) as f64;
        let iters: f64 = records
            .iter()
            .filter_map(|r| r.report.map(|x| x.solve.iterations as f64))
            .sum::<f64>()
            / steps.max(1) as f64;
        println!(
            "  {case} {:<19} n={} steps={steps} t={:.5} ΔV/V₀ moments {:+.3e} hull {:+.3e}  a {:.4} ({:.4}) b {:.4} ({:.4})  p_c {:.1} ({:.1})  iters/step {iters:.1}  {:.3} s/step  [{:.1} s]",
            scheme.name(),
            n_particles,
            last.t,
            drop::volume_change(&records),
            last.measure_hull / records[0].measure_hull - 1.0,
            last.semi_axes[0],
            last.exact.a,
            last.semi_axes[1],
            last.exact.b,
            last.p_centre,
            last.exact.p_c,
            mean_step,
            t0.elapsed().as_secs_f64(),
        );
        checks.extend(drop::checks(case, D::DIM, scheme, &records));
        infos.push(RunInfo {
            case: case.to_string(),
            scheme: scheme.name().to_string(),
            kernel: format!("{:?}", scene.kernel),
            dim: D::DIM,
            particles: n_particles,
            steps,
            wall_s: t0.elapsed().as_secs_f64(),
            solver_iters_mean: iters,
        });
        runs.push((scheme, records));
    }
    let find = |k: SchemeKind| runs.iter().find(|(s, _)| *s == k).map(|(_, r)| r);
    if let (Some(e), Some(g)) = (find(SchemeKind::Euler), find(SchemeKind::Dg)) {
        checks.push(drop::euler_vs_dg_check(case, e, g));
    }
    Ok(SceneResult {
        checks,
        runs: infos,
    })
}

fn run_prescribed<D: Dim>(scene: &Scene, out: &Path) -> anyhow::Result<SceneResult> {
    let t0 = std::time::Instant::now();
    let (runs, checks) = prescribed::run_scene::<D>(scene);
    let wall_s = t0.elapsed().as_secs_f64();
    let mut infos = Vec::new();
    for run in &runs {
        let path = csv_path(out, scene, run.update.name());
        let mut w = std::io::BufWriter::new(
            std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?,
        );
        writeln!(w, "t,measure_hull,measure_moments")?;
        for (t, h, m) in &run.series {
            writeln!(w, "{t:.9e},{h:.15e},{m:.15e}")?;
        }
        println!(
            "  {} {:<5} n={} slope hull {:+.9e} moments {:+.9e} exact {:+.9e}",
            scene.case.name(),
            run.update.name(),
            run.particles,
            run.slope_hull,
            run.slope_moments,
            run.exact_slope
        );
        infos.push(RunInfo {
            case: scene.case.name().to_string(),
            scheme: run.update.name().to_string(),
            kernel: "none".to_string(),
            dim: D::DIM,
            particles: run.particles,
            steps: run.series.len() - 1,
            wall_s: wall_s / runs.len() as f64,
            solver_iters_mean: 0.0,
        });
    }
    Ok(SceneResult {
        checks,
        runs: infos,
    })
}
