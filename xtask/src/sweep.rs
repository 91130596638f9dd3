//! `cargo xtask validate --sweep`: accuracy against cost.
//!
//! Every scheme is run over three resolutions (Δt refined with dx at a fixed CFL number), both
//! kernels and two solvers on two cases — the 2D elliptical drop (error: the semi-axis `a` at the
//! end time against the exact solution; also the second-moment volume change) and the Re = 100
//! cavity (error: RMS deviation from Ghia et al., the larger of u and v) — plus a Δt-only
//! refinement of the drop at fixed dx, and a solver study: the pressure solve's relative
//! tolerance from 1e-2 to 1e-8, warm-started or from zero, for every scheme on the drop and the
//! 20² cavity (AMG). It writes `sweep.csv`, `sweep.md` (the table with the
//! Pareto-optimal runs marked, and the observed convergence orders) and one error-against-wall-
//! time plot per case.

use anyhow::Context;
use dgsph::report::{Series, line_plot};
use dgsph::session::AppError;
use sph_cases::Scene;
use sph_cases::reference::References;
use sph_cases::registry;
use sph_cases::run::{MemorySink, RunControl};
use sph_integrators::SchemeKind;
use sph_kernels::KernelKind;
use sph_pressure::SolverKind;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// One run of the sweep.
#[derive(Clone, Debug)]
struct Point {
    case: &'static str,
    study: &'static str,
    scheme: SchemeKind,
    kernel: KernelKind,
    solver: SolverKind,
    /// Relative residual tolerance of the pressure solve, and whether it is warm-started.
    tolerance: f64,
    warm: bool,
    dx: f64,
    dt: f64,
    particles: usize,
    steps: usize,
    wall_s: f64,
    /// The case's error measure (NaN if the run failed).
    error: f64,
    /// A second measure: |ΔV/V₀| for the drop, RMS density error for the cavity.
    error2: f64,
    status: String,
}

const SCHEMES: [SchemeKind; 3] = [
    SchemeKind::Euler,
    SchemeKind::PredictorCorrector,
    SchemeKind::Dg,
];
const KERNELS: [KernelKind; 2] = [KernelKind::QuinticSpline, KernelKind::WendlandC2];
const SOLVERS: [SolverKind; 3] = [
    SolverKind::BicgstabAmg,
    SolverKind::BicgstabJacobi,
    SolverKind::BicgstabIlu0,
];

/// What one run measured: `(particles, steps, error, error2, status)`.
type Measured = (usize, usize, f64, f64, String);

impl Point {
    /// Times `run` on `scene` (one scheme) and records what it measured; a failed run is a
    /// point with NaN errors and the failure as its status.
    fn measure(
        case: &'static str,
        study: &'static str,
        scene: &Scene,
        run: impl FnOnce() -> Result<Measured, sph_cases::CaseError>,
    ) -> Self {
        let t0 = Instant::now();
        let outcome = run();
        let wall_s = t0.elapsed().as_secs_f64();
        let (particles, steps, error, error2, status) =
            outcome.unwrap_or_else(|e| (0, 0, f64::NAN, f64::NAN, format!("failed: {e}")));
        Point {
            case,
            study,
            scheme: scene.schemes[0],
            kernel: scene.kernel,
            solver: scene.solver,
            tolerance: scene.solver_tolerance.unwrap_or(1e-9),
            warm: scene.solver_warm_start,
            dx: scene.dx,
            dt: scene.dt,
            particles,
            steps,
            wall_s,
            error,
            error2,
            status,
        }
    }
}

/// Runs `scene`'s first scheme in memory.
fn run_one(
    scene: &Scene,
    refs: &References,
) -> Result<(sph_cases::run::SchemeRun, MemorySink), sph_cases::CaseError> {
    let mut sink = MemorySink::default();
    let r = registry::run_scheme(
        scene,
        scene.schemes[0],
        refs,
        RunControl::default(),
        &mut sink,
    )?;
    Ok((r, sink))
}

fn status(r: &sph_cases::run::SchemeRun, dx: f64) -> String {
    if let Some(e) = &r.failure {
        return format!("failed: {e}");
    }
    let pen = r
        .results
        .get("max_wall_penetrations")
        .copied()
        .unwrap_or(0.0);
    if pen > 0.0 {
        format!(
            "{pen} wall penetrations ({:.3} dx deep)",
            r.results
                .get("max_wall_intrusion_dx")
                .copied()
                .unwrap_or(f64::NAN)
        )
    } else {
        let _ = dx;
        "ok".to_string()
    }
}

fn drop_point(scene: &Scene, refs: &References, study: &'static str) -> Point {
    Point::measure("elliptical_drop", study, scene, || {
        let (r, _) = run_one(scene, refs)?;
        let get = |k: &str| r.results.get(k).copied().unwrap_or(f64::NAN);
        Ok((
            r.particles.0 + r.particles.1,
            r.step,
            get("a_error_moments").abs(),
            get("volume_change").abs(),
            status(&r, scene.dx),
        ))
    })
}

fn cavity_point(scene: &Scene, refs: &References, study: &'static str) -> Point {
    Point::measure("cavity_re100", study, scene, || {
        let (r, sink) = run_one(scene, refs)?;
        let get = |k: &str| r.results.get(k).copied().unwrap_or(f64::NAN);
        Ok((
            r.particles.0 + r.particles.1,
            r.step,
            get("ghia_u_rms").max(get("ghia_v_rms")),
            sink.last("density_error_rms"),
            status(&r, scene.dx),
        ))
    })
}

/// Least-squares slope of ln(error) against ln(x) over the finite, positive points.
fn order(points: &[(f64, f64)]) -> Option<f64> {
    let p: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, e)| *x > 0.0 && *e > 0.0 && e.is_finite())
        .map(|(x, e)| (x.ln(), e.ln()))
        .collect();
    if p.len() < 2 {
        return None;
    }
    let n = p.len() as f64;
    let (mx, my) = (
        p.iter().map(|q| q.0).sum::<f64>() / n,
        p.iter().map(|q| q.1).sum::<f64>() / n,
    );
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Indices of the Pareto-optimal points (no other point is both faster and more accurate).
fn pareto(points: &[&Point]) -> Vec<usize> {
    let ok = |p: &Point| p.error.is_finite() && p.status == "ok";
    (0..points.len())
        .filter(|&i| {
            ok(points[i])
                && !points.iter().any(|q| {
                    ok(q)
                        && q.wall_s <= points[i].wall_s
                        && q.error <= points[i].error
                        && (q.wall_s < points[i].wall_s || q.error < points[i].error)
                })
        })
        .collect()
}

/// Runs the sweep (only the `studies` named, if any) and writes its outputs into `out`.
pub fn run(
    cases: &Path,
    out: &Path,
    refs: &References,
    studies: &[String],
) -> Result<(), AppError> {
    let wanted = |s: &str| studies.is_empty() || studies.iter().any(|w| w == s);
    // Its scenes are input (exit 2); only the directory and the files are output (exit 4).
    let drop_scene = dgsph::session::load_scene(&cases.join("elliptical_drop.toml"))
        .map_err(|e| AppError::Input(anyhow::anyhow!("{e}")))?;
    let cavity_scene = dgsph::session::load_scene(&cases.join("cavity_re100.toml"))
        .map_err(|e| AppError::Input(anyhow::anyhow!("{e}")))?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("creating {}", out.display()))
        .map_err(AppError::Output)?;
    let mut points = Vec::new();
    let mut progress = |p: Point| {
        dgsph::say!(
            "  {:<16} {:<9} {:<19} {:<14} {:<15} tol {:.0e}{} dx {:<7} dt {:<8.1e} n {:>6}  error {:.3e}  wall {:>7.2} s  {}",
            p.case,
            p.study,
            p.scheme.name(),
            p.kernel.name(),
            p.solver.name(),
            p.tolerance,
            if p.warm { "" } else { " cold" },
            p.dx,
            p.dt,
            p.particles,
            p.error,
            p.wall_s,
            p.status
        );
        points.push(p);
    };
    // Drop: dx with Δt ∝ dx (fixed CFL), every kernel and solver.
    for &scheme in &SCHEMES {
        for &kernel in KERNELS.iter().filter(|_| wanted("dx")) {
            for &solver in &SOLVERS {
                for k in [1.0, 0.5, 0.25] {
                    let scene = Scene {
                        schemes: vec![scheme],
                        kernel,
                        solver,
                        dx: 0.05 * k,
                        dt: 4e-4 * k,
                        ..drop_scene.clone()
                    };
                    progress(drop_point(&scene, refs, "dx"));
                }
            }
        }
        // Drop: Δt alone at the scene's dx and kernel.
        for dt in [4e-4, 2e-4, 1e-4, 5e-5]
            .into_iter()
            .filter(|_| wanted("dt"))
        {
            let scene = Scene {
                schemes: vec![scheme],
                dt,
                ..drop_scene.clone()
            };
            progress(drop_point(&scene, refs, "dt"));
        }
    }
    // Cavity Re 100: dx ∈ {1/10, 1/16, 1/20} at the scene's Δt and end time.
    for &scheme in &SCHEMES {
        for &kernel in KERNELS.iter().filter(|_| wanted("dx")) {
            for &solver in &SOLVERS {
                for m in [10.0, 16.0, 20.0] {
                    let scene = Scene {
                        schemes: vec![scheme],
                        kernel,
                        solver,
                        dx: 1.0 / m,
                        ..cavity_scene.clone()
                    };
                    progress(cavity_point(&scene, refs, "dx"));
                }
            }
        }
    }
    // Solver tolerance and warm start, every scheme, at the drop scene's resolution and at the
    // cavity's 20² (AMG, as the larger cavity scenes declare).
    for &scheme in SCHEMES.iter().filter(|_| wanted("tolerance")) {
        for warm in [true, false] {
            for tol in TOLERANCES {
                let drop = Scene {
                    schemes: vec![scheme],
                    solver_tolerance: Some(tol),
                    solver_warm_start: warm,
                    ..drop_scene.clone()
                };
                progress(drop_point(&drop, refs, "tolerance"));
                let cavity = Scene {
                    schemes: vec![scheme],
                    solver: SolverKind::BicgstabAmg,
                    solver_tolerance: Some(tol),
                    solver_warm_start: warm,
                    dx: 1.0 / 20.0,
                    ..cavity_scene.clone()
                };
                progress(cavity_point(&cavity, refs, "tolerance"));
            }
        }
    }
    write_outputs(out, &points).map_err(AppError::Output)
}

/// Solver tolerances of the tolerance study.
const TOLERANCES: [f64; 5] = [1e-2, 1e-3, 1e-4, 1e-6, 1e-8];

fn write_outputs(out: &Path, points: &[Point]) -> anyhow::Result<()> {
    let mut csv = String::from(
        "case,study,scheme,kernel,solver,tolerance,warm_start,dx,dt,particles,steps,wall_s,error,error2,pareto,status\n",
    );
    let mut md = String::from(
        "# Accuracy against cost\n\n`cargo xtask validate --sweep`. Errors: elliptical drop — \
         |a/a_exact − 1| at the end time (error 2: |ΔV/V₀|, second moments); cavity Re 100 — \
         RMS deviation from Ghia et al., the larger of u and v (error 2: RMS density error, \
         Eq. 31). ★ marks the Pareto front (no run is both faster and more accurate). Wall \
         times are one run each on this machine, measured in the same sweep.\n\n",
    );
    let cases: Vec<&str> = {
        let mut c: Vec<&str> = points.iter().map(|p| p.case).collect();
        c.dedup();
        c
    };
    for case in cases {
        let mut rows: Vec<&Point> = points.iter().filter(|p| p.case == case).collect();
        rows.sort_by(|a, b| a.wall_s.total_cmp(&b.wall_s));
        let front = pareto(&rows);
        let _ = writeln!(
            md,
            "## {case}\n\n| | study | scheme | kernel | solver | tolerance | dx | Δt | particles | steps | wall (s) | error | error 2 | status |\n|---|---|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|"
        );
        for (i, p) in rows.iter().enumerate() {
            let star = front.contains(&i);
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {:.0e}{} | {:.4} | {:.1e} | {} | {} | {:.2} | {:.3e} | {:.3e} | {} |",
                if star { "★" } else { "" },
                p.study,
                p.scheme.name(),
                p.kernel.name(),
                p.solver.name(),
                p.tolerance,
                if p.warm { "" } else { ", cold" },
                p.dx,
                p.dt,
                p.particles,
                p.steps,
                p.wall_s,
                p.error,
                p.error2,
                p.status
            );
            let _ = writeln!(
                csv,
                "{},{},{},{},{},{:e},{},{},{},{},{},{:.4},{:.6e},{:.6e},{},{}",
                p.case,
                p.study,
                p.scheme.name(),
                p.kernel.name(),
                p.solver.name(),
                p.tolerance,
                p.warm,
                p.dx,
                p.dt,
                p.particles,
                p.steps,
                p.wall_s,
                p.error,
                p.error2,
                star,
                p.status.replace(',', ";")
            );
        }
        // Observed orders: slope of ln(error) on ln(dx) (Δt ∝ dx) or ln(Δt).
        let _ = writeln!(
            md,
            "\nObserved convergence orders (least-squares slope of ln error on ln dx, Δt ∝ dx; \
             or on ln Δt at fixed dx):\n\n| study | scheme | kernel | solver | order (error) | order (error 2) |\n|---|---|---|---|---:|---:|"
        );
        let mut families: Vec<(&str, SchemeKind, KernelKind, SolverKind)> = rows
            .iter()
            .filter(|p| p.study != "tolerance")
            .map(|p| (p.study, p.scheme, p.kernel, p.solver))
            .collect();
        families.sort_by_key(|f| (f.0, f.1.name(), f.2.name(), f.3.name()));
        families.dedup();
        for (study, scheme, kernel, solver) in families {
            let fam: Vec<&&Point> = rows
                .iter()
                .filter(|p| {
                    p.study == study
                        && p.scheme == scheme
                        && p.kernel == kernel
                        && p.solver == solver
                })
                .collect();
            let x = |p: &Point| if study == "dt" { p.dt } else { p.dx };
            let o1 = order(&fam.iter().map(|p| (x(p), p.error)).collect::<Vec<_>>());
            let o2 = order(&fam.iter().map(|p| (x(p), p.error2)).collect::<Vec<_>>());
            let f = |o: Option<f64>| o.map_or("—".to_string(), |o| format!("{o:.2}"));
            let _ = writeln!(
                md,
                "| {study} | {} | {} | {} | {} | {} |",
                scheme.name(),
                kernel.name(),
                solver.name(),
                f(o1),
                f(o2)
            );
        }
        // Plot: error against wall time per scheme, and the front.
        let mut series: Vec<Series> = SCHEMES
            .iter()
            .map(|s| {
                Series::markers(
                    s.name(),
                    rows.iter()
                        .filter(|p| p.scheme == *s)
                        .map(|p| (p.wall_s, p.error))
                        .collect(),
                )
            })
            .collect();
        series.push(Series::exact(
            "Pareto front",
            front
                .iter()
                .map(|&i| (rows[i].wall_s, rows[i].error))
                .collect(),
        ));
        let file = format!("sweep_{case}.svg");
        if line_plot(
            &out.join(&file),
            &format!("{case}: error against wall time"),
            "wall time (s)",
            "error",
            &series,
            true,
        )? {
            let _ = writeln!(md, "\n![{case}]({file})\n");
        }
    }
    let csv_path = out.join("sweep.csv");
    dgsph::output::write_atomic(&csv_path, csv.as_bytes())
        .with_context(|| format!("writing {}", csv_path.display()))?;
    let md_path = out.join("sweep.md");
    dgsph::output::write_atomic(&md_path, md.as_bytes())
        .with_context(|| format!("writing {}", md_path.display()))?;
    dgsph::say!("sweep: {} and {}", md_path.display(), csv_path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_recovers_a_power_law() {
        let pts: Vec<(f64, f64)> = [0.1, 0.05, 0.025]
            .iter()
            .map(|&h: &f64| (h, 3.0 * h.powi(2)))
            .collect();
        assert!((order(&pts).unwrap() - 2.0).abs() < 1e-12);
        assert_eq!(order(&[(0.1, 1.0)]), None);
    }

    #[test]
    fn pareto_front_drops_dominated_and_failed_runs() {
        let p = |wall_s: f64, error: f64, status: &str| Point {
            case: "c",
            study: "dx",
            scheme: SchemeKind::Dg,
            kernel: KernelKind::WendlandC2,
            solver: SolverKind::BicgstabJacobi,
            tolerance: 1e-6,
            warm: true,
            dx: 0.1,
            dt: 0.1,
            particles: 1,
            steps: 1,
            wall_s,
            error,
            error2: 0.0,
            status: status.into(),
        };
        let pts = [
            p(1.0, 0.1, "ok"),
            p(2.0, 0.2, "ok"),
            p(3.0, 0.01, "ok"),
            p(0.5, 0.001, "failed: x"),
        ];
        let refs: Vec<&Point> = pts.iter().collect();
        assert_eq!(pareto(&refs), vec![0, 2]);
    }
}
