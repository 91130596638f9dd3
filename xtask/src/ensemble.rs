//! `cargo xtask ensemble SCENE`: how far round-off moves a run's results. A flow whose
//! particles move chaotically (the cavities' disorder, a breaking surge) answers a change in
//! the last bit of any value with a different particle history, and a snapshot measured at one
//! time — the Ghia deviations at t = 10, say — with a different value. One run is then one
//! draw from a distribution, and two codes (or settings) are compared by their distributions,
//! not by one draw each.
//!
//! Draw `k = 0, 1, …, N − 1` runs the scene with the time step `Δt (1 − k ε)` (default `ε = 1e-14`,
//! a change far below any discretisation error), taken every step. Every draw ends at the scene's
//! end time: when its full steps fall short of it by more than `1e-9 Δt` (from about `k ε n >
//! 1e-9`, `n` steps: k ≥ 7 for the 16 000 steps of the Re 400 cavity) the run adds a last step of
//! that length, as any run whose end time is not a whole number of steps does. With `--perturb
//! gravity` draw `k` runs with the gravity vector `g (1 − k ε)` instead and the scene's own time
//! step, automatic or not (a scene under gravity whose step is chosen from the state: the
//! dam breaks, the drops). Every scheme of the scene is run in every
//! draw, in memory (no frames, no records on disk). Writes `<tag>_ensemble.csv` (one row per draw,
//! scheme and result: `scheme,draw,dt,status,result,value`) and `<tag>_ensemble.md` (per scheme and
//! result: draws, mean, standard deviation, standard error of the mean, minimum, maximum) into
//! `--out`. The scene's checks are not evaluated: the ensemble reports values. A draw whose run
//! fails is listed with its error and left out of the statistics; the exit code is then 3
//! (`dgsph`'s "a run failed"), otherwise 0.

use crate::flags::{EnsembleArgs, Perturbed};
use anyhow::Context;
use dgsph::session::{self, AppError, exit};
use sph_cases::reference::References;
use sph_cases::registry;
use sph_cases::run::{MemorySink, RunControl};
use std::fmt::Write as _;

/// The header of `<tag>_ensemble.csv`, written here and read by `ensemble-compare`.
pub const CSV_HEADER: &str = "scheme,draw,dt,status,result,value";

/// Largest total relative change of the time step over the draws, `(N − 1) ε`.
const MAX_SPREAD: f64 = 1e-6;

/// One run of one draw.
struct Draw {
    scheme: &'static str,
    k: usize,
    dt: f64,
    /// `None` when the run completed; the error's first words otherwise.
    failure: Option<String>,
    results: Vec<(String, f64)>,
}

/// Mean, sample standard deviation, standard error of the mean, minimum and maximum of the
/// finite values (`n` of them; the spread measures need `n ≥ 2`, else NaN).
#[derive(Debug, PartialEq)]
pub struct Stats {
    pub n: usize,
    pub mean: f64,
    pub sd: f64,
    pub se: f64,
    pub min: f64,
    pub max: f64,
}

/// The statistics of the finite values among `values`.
pub fn stats(values: &[f64]) -> Stats {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    let n = v.len();
    if n == 0 {
        return Stats {
            n,
            mean: f64::NAN,
            sd: f64::NAN,
            se: f64::NAN,
            min: f64::NAN,
            max: f64::NAN,
        };
    }
    let mean = v.iter().sum::<f64>() / n as f64;
    let (sd, se) = if n > 1 {
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        (var.sqrt(), (var / n as f64).sqrt())
    } else {
        (f64::NAN, f64::NAN)
    };
    Stats {
        n,
        mean,
        sd,
        se,
        min: v.iter().copied().fold(f64::INFINITY, f64::min),
        max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    }
}

/// The time step (or a gravity component) of draw `k`: `x (1 − k ε)`.
pub fn draw_dt(dt: f64, k: usize, epsilon: f64) -> f64 {
    dt * (1.0 - k as f64 * epsilon)
}

/// What the draws change, as the reports name it: `Δt = 0.002` or `g = [0.0, -9.81, 0.0]
/// (Δt as the scene's)`.
fn drawn(perturb: Perturbed, scene: &sph_cases::Scene) -> String {
    match perturb {
        Perturbed::Dt => format!("Δt = {:?}", scene.dt),
        Perturbed::Gravity => format!(
            "g = {:?} (Δt as the scene's, {})",
            scene.effects.gravity.unwrap_or_default(),
            if scene.auto_time_step().is_some() {
                format!("automatic, at most {:?}", scene.dt)
            } else {
                format!("fixed {:?}", scene.dt)
            }
        ),
    }
}

/// Runs the ensemble; returns the exit code.
pub fn run(args: &EnsembleArgs) -> Result<u8, AppError> {
    let eps = args.perturbation;
    if !(eps.is_finite() && eps > 0.0) {
        return Err(AppError::Input(anyhow::anyhow!(
            "--perturbation must be a positive number, got {eps}"
        )));
    }
    let what = match args.perturb {
        Perturbed::Dt => "the time step",
        Perturbed::Gravity => "gravity",
    };
    let spread = (args.draws - 1) as f64 * eps;
    if spread > MAX_SPREAD {
        return Err(AppError::Input(anyhow::anyhow!(
            "--draws {} × --perturbation {eps} changes {what} by up to {spread:e} \
             (more than {MAX_SPREAD:e}): the draws would differ by more than round-off",
            args.draws
        )));
    }
    let scene = session::load_scene(&args.scene)?;
    let scene = args.overrides.apply(args.preset.apply(&scene))?;
    if args.perturb == Perturbed::Gravity
        && scene
            .effects
            .gravity
            .is_none_or(|g| g.iter().all(|c| *c == 0.0))
    {
        return Err(AppError::Input(anyhow::anyhow!(
            "--perturb gravity: {} has no gravity to perturb ([effects] gravity)",
            args.scene.display()
        )));
    }
    let tag = args
        .tag
        .clone()
        .unwrap_or_else(|| session::scene_stem(&args.scene));
    let refs = References::embedded();
    dgsph::say!(
        "{}: {} draws, {} (1 − k·{eps:e}), schemes {}",
        args.scene.display(),
        args.draws,
        drawn(args.perturb, &scene),
        scene
            .schemes
            .iter()
            .map(|s| s.name())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut draws = Vec::new();
    for k in 0..args.draws as usize {
        let mut s = scene.clone();
        match args.perturb {
            Perturbed::Dt => {
                s.dt = draw_dt(scene.dt, k, eps);
                // The drawn step is taken every step (an automatic step would only be bounded
                // by it).
                s.time_step.auto = Some(false);
            }
            Perturbed::Gravity => {
                s.effects.gravity = scene.effects.gravity.map(|g| g.map(|c| draw_dt(c, k, eps)));
            }
        }
        for &scheme in &scene.schemes {
            let mut sink = MemorySink::default();
            let r = registry::run_scheme(&s, scheme, refs, RunControl::default(), &mut sink)
                .map_err(|e| AppError::Input(e.into()))?;
            let failure = r.failure.as_ref().map(|e| {
                let text = e.to_string();
                text.split(';').next().unwrap_or(&text).to_string()
            });
            let shown: Vec<String> = r
                .results
                .iter()
                .filter(|(key, _)| key.starts_with("ghia_"))
                .map(|(key, v)| format!("{key} {v:.6e}"))
                .collect();
            dgsph::say!(
                "  {} k = {k}: {}, t = {:.4}, {:.1} s, {}{}",
                scheme.name(),
                match args.perturb {
                    Perturbed::Dt => format!("Δt = {:?}", s.dt),
                    Perturbed::Gravity =>
                        format!("g = {:?}", s.effects.gravity.unwrap_or_default()),
                },
                r.t,
                r.wall_s,
                failure.as_deref().unwrap_or("completed"),
                if shown.is_empty() {
                    String::new()
                } else {
                    format!("; {}", shown.join(", "))
                }
            );
            draws.push(Draw {
                scheme: scheme.name(),
                k,
                dt: s.dt,
                failure,
                results: r.results.into_iter().collect(),
            });
        }
    }
    let (csv, md) = tables(&draws, &tag, args, &scene);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))
        .map_err(AppError::Output)?;
    for (name, text) in [
        (format!("{tag}_ensemble.csv"), &csv),
        (format!("{tag}_ensemble.md"), &md),
    ] {
        let path = args.out.join(name);
        dgsph::output::write_atomic(&path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))
            .map_err(AppError::Output)?;
        dgsph::say!("wrote {}", path.display());
    }
    dgsph::say_part!("{md}");
    Ok(if draws.iter().any(|d| d.failure.is_some()) {
        exit::RUN_FAILED
    } else {
        exit::OK
    })
}

/// The CSV of every draw and the Markdown summary.
fn tables(
    draws: &[Draw],
    tag: &str,
    args: &EnsembleArgs,
    scene: &sph_cases::Scene,
) -> (String, String) {
    let mut csv = format!("{CSV_HEADER}\n");
    for d in draws {
        let status = if d.failure.is_some() {
            "failed"
        } else {
            "completed"
        };
        for (key, v) in &d.results {
            let _ = writeln!(csv, "{},{},{:?},{status},{key},{v:?}", d.scheme, d.k, d.dt);
        }
    }
    let mut md = format!(
        "# Round-off ensemble: {tag}\n\n`cargo xtask ensemble {}` — {} draws, {} \
         (1 − k ε), ε = {:e}, k = 0 … {}. Statistics over the completed draws; SE is the \
         standard error of the mean (SD/√n).\n\nThe scene as run ({} preset, command-line \
         overrides applied): {}D, dx = {:?}, t_end = {:?}, kernel {}, solver {}, tolerance {}.\n\n",
        args.scene.display(),
        args.draws,
        drawn(args.perturb, scene),
        args.perturbation,
        args.draws - 1,
        args.preset.name(),
        scene.dim,
        scene.dx,
        scene.t_end,
        scene.kernel.name(),
        scene.solver.name(),
        scene
            .solver_tolerance
            .map_or_else(|| "the solver's default".to_string(), |t| format!("{t:e}")),
    );
    for &scheme in &scene.schemes {
        let mine: Vec<&Draw> = draws.iter().filter(|d| d.scheme == scheme.name()).collect();
        let done: Vec<&&Draw> = mine.iter().filter(|d| d.failure.is_none()).collect();
        let _ = writeln!(
            md,
            "## {}\n\n{} of {} draws completed.",
            scheme.name(),
            done.len(),
            mine.len()
        );
        for d in mine.iter().filter(|d| d.failure.is_some()) {
            let _ = writeln!(
                md,
                "- draw {} (Δt = {:?}) failed: {}",
                d.k,
                d.dt,
                d.failure.as_deref().unwrap_or_default()
            );
        }
        let _ = writeln!(
            md,
            "\n| result | n | mean | SD | SE | min | max |\n|---|---:|---:|---:|---:|---:|---:|"
        );
        let keys: Vec<&String> = done
            .first()
            .map(|d| d.results.iter().map(|(k, _)| k).collect())
            .unwrap_or_default();
        for key in keys {
            let values: Vec<f64> = done
                .iter()
                .filter_map(|d| d.results.iter().find(|(k, _)| k == key).map(|(_, v)| *v))
                .collect();
            let s = stats(&values);
            let _ = writeln!(
                md,
                "| {key} | {} | {:.6e} | {:.3e} | {:.3e} | {:.6e} | {:.6e} |",
                s.n, s.mean, s.sd, s.se, s.min, s.max
            );
        }
        md.push('\n');
    }
    (csv, md)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_a_known_sample() {
        // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, sum of squared deviations 32, sample variance 32/7.
        let s = stats(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0, f64::NAN]);
        assert_eq!(s.n, 8);
        assert_eq!(s.mean, 5.0);
        assert!((s.sd - (32.0f64 / 7.0).sqrt()).abs() < 1e-15, "{s:?}");
        assert!((s.se - (32.0f64 / 7.0 / 8.0).sqrt()).abs() < 1e-15, "{s:?}");
        assert_eq!((s.min, s.max), (2.0, 9.0));
        let one = stats(&[3.0]);
        assert_eq!((one.n, one.mean, one.min, one.max), (1, 3.0, 3.0, 3.0));
        assert!(one.sd.is_nan() && one.se.is_nan());
        assert_eq!(stats(&[f64::INFINITY]).n, 0);
    }

    #[test]
    fn draws_perturb_the_step_downwards_by_k_epsilon() {
        assert_eq!(draw_dt(0.0025, 0, 1e-14), 0.0025);
        for k in 1..9 {
            let dt = draw_dt(0.0025, k, 1e-14);
            let rel = 1.0 - dt / 0.0025;
            assert!((rel - k as f64 * 1e-14).abs() < 2e-16, "k = {k}: {rel:e}");
        }
    }
}
