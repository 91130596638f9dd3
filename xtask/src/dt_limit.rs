//! `cargo xtask dt-limit`: the largest stable time step of each scheme, by bisection on the
//! CFL number `C = U Δt / h` (`U`: the run's velocity scale, see `max_speed_ratio`), for the
//! elliptical drop, the Re 400 cavity and the dam break (their quick sizes unless `--preset
//! full`).
//!
//! A trial runs the scene with the trial `Δt` to a fixed end time and is **stable** when it
//! reaches the end with no failed step (non-finite values, a solver that does not converge, a
//! particle escaping the walls), no wall penetration, and speeds bounded by three times the
//! velocity scale. The displacement limit of blow-up detection is raised to 10 h for these
//! trials, so it does not cap `Δt` by itself. The search doubles `Δt` from the scene's value
//! (the last doubling clipped to the cap below) until a trial is unstable, then bisects five times; the result brackets the limit to within
//! 1/32 of the first unstable step. A trial has at least five full steps: when `Δt = T/5` is
//! still stable the table says so (`≥`) instead of a limit. A start that is unstable is halved
//! (at most five times) before the search. Writes `dt_limit.md` and `dt_limit.csv` into `--out`.
//!
//! `--scene FILE --end T --dx a,b,c` searches other scenes at several spacings (the search
//! starting from the scene's Δt scaled with dx): a stability map, drawn as `dt_limit.svg`
//! (stable Δt against dx, one line per scene and scheme).

use crate::flags::DtLimitArgs;
use anyhow::Context;
use dgsph::report::{Series, line_plot};
use dgsph::session::{self, AppError, exit};
use sph_cases::reference::References;
use sph_cases::run::{MemorySink, RunControl};
use sph_cases::{Scene, registry};
use sph_integrators::SchemeKind;
use std::fmt::Write as _;
use std::path::PathBuf;

/// The scenes searched: file, end time of every trial.
const SCENES: [(&str, f64); 3] = [
    ("cases/elliptical_drop.toml", 0.003),
    ("cases/cavity_re400.toml", 2.0),
    ("cases/hard/dam_break.toml", 1.5),
];

/// One trial: stable or not, and why not.
fn trial(scene: &Scene, scheme: SchemeKind, dt: f64, refs: &References) -> (bool, String, f64) {
    let mut s = scene.clone();
    s.dt = dt;
    // A trial is a fixed step: the automatic one would only be bounded by it.
    s.time_step.auto = Some(false);
    s.schemes = vec![scheme];
    s.limits.max_displacement = Some(10.0);
    s.output.sample_every = Some(1);
    let mut sink = MemorySink::default();
    let t0 = std::time::Instant::now();
    let run = registry::run_scheme(&s, scheme, refs, RunControl::default(), &mut sink);
    let wall = t0.elapsed().as_secs_f64();
    match run {
        Err(e) => (false, format!("setup: {e}"), wall),
        Ok(r) => {
            let get = |k: &str| r.results.get(k).copied().unwrap_or(f64::NAN);
            if let Some(e) = &r.failure {
                (false, first_words(&e.to_string()), wall)
            } else if get("max_wall_penetrations") > 0.0 {
                (false, "wall penetration".into(), wall)
            } else if get("max_speed_ratio").is_nan() || get("max_speed_ratio") > 3.0 {
                (
                    false,
                    format!("max |u|/U = {:.2}", get("max_speed_ratio")),
                    wall,
                )
            } else {
                (true, String::new(), wall)
            }
        }
    }
}

fn first_words(s: &str) -> String {
    s.split(';').next().unwrap_or(s).chars().take(90).collect()
}

/// Velocity scale and smoothing length of a scene (for the CFL number).
fn scale(scene: &Scene, refs: &References) -> f64 {
    // One zero-length trial gives the run loop's velocity scale through max_speed_ratio.
    let mut s = scene.clone();
    s.t_end = s.dt;
    s.schemes = vec![SchemeKind::Euler];
    let mut sink = MemorySink::default();
    registry::run_scheme(
        &s,
        SchemeKind::Euler,
        refs,
        RunControl::default(),
        &mut sink,
    )
    .ok()
    .map_or(f64::NAN, |r| {
        let get = |k: &str| r.results.get(k).copied().unwrap_or(f64::NAN);
        // max_speed_ratio = max_speed / U over one step; the initial speed is the scale for
        // moving starts, √(gH) for fluid at rest, the lid speed for the cavity.
        get("max_speed") / get("max_speed_ratio")
    })
}

/// Runs the search; returns the exit code.
pub fn run(args: &DtLimitArgs) -> Result<u8, AppError> {
    let refs = References::embedded();
    let mut md = String::from(
        "# Largest stable time step\n\n`cargo xtask dt-limit` (see `xtask/src/dt_limit.rs` for \
         the stability criterion). C = U Δt / h.\n\n| scene | dx | particles | scheme | stable Δt | \
         C | first unstable Δt | C | why | trials | wall s |\n|---|---:|---:|---|---:|---:|---:|---:|---|---:|---:|\n",
    );
    let mut csv =
        String::from("scene,dx,scheme,dt_stable,cfl_stable,dt_unstable,cfl_unstable,reason\n");
    let jobs: Vec<(PathBuf, Option<f64>)> = if args.scene.is_empty() {
        SCENES
            .iter()
            .map(|(f, t)| (PathBuf::from(f), Some(*t)))
            .collect()
    } else {
        args.scene.iter().map(|f| (f.clone(), args.end)).collect()
    };
    // Stable Δt against dx, per scene and scheme (the map's lines).
    let mut map: Vec<Series> = Vec::new();
    for (path, t_end) in &jobs {
        let loaded = session::load_scene(path)?;
        let base = args.preset.apply(&loaded);
        let spacings = if args.dx.is_empty() {
            vec![base.dx]
        } else {
            args.dx.clone()
        };
        let mut lines: Vec<Vec<(f64, f64)>> = vec![Vec::new(); 3];
        for &dx in &spacings {
            let mut scene = base.clone();
            if let Some(t) = t_end {
                scene.t_end = *t;
            }
            scene.dt = base.dt * dx / base.dx;
            scene.dx = dx;
            let name = session::scene_stem(path);
            // `--dx` and `--end` are bad input where the scene would be.
            let what = format!(
                "{} with --dx {dx} and --end {}",
                path.display(),
                scene.t_end
            );
            scene
                .validate(&what)
                .and_then(|()| registry::validate(&scene, &what))
                .map_err(|e| AppError::Input(e.into()))?;
            let u = scale(&scene, refs);
            let h = scene.h();
            let (fluid, walls, _) =
                registry::particle_counts(&scene, refs).map_err(|e| AppError::Input(e.into()))?;
            for (line, &scheme) in [
                SchemeKind::Euler,
                SchemeKind::PredictorCorrector,
                SchemeKind::Dg,
            ]
            .iter()
            .enumerate()
            {
                let t0 = std::time::Instant::now();
                let mut trials = 0;
                let mut lo = scene.dt;
                let (mut ok, mut why, _) = trial(&scene, scheme, lo, refs);
                trials += 1;
                for _ in 0..5 {
                    if ok {
                        break;
                    }
                    lo *= 0.5;
                    (ok, why, _) = trial(&scene, scheme, lo, refs);
                    trials += 1;
                }
                if !ok {
                    let _ = writeln!(
                        md,
                        "| {name} | {dx} | {} | {} | — | — | {lo:.3e} | {:.3} | {why} (at 1/32 of the scene's Δt) | {trials} | {:.0} |",
                        fluid + walls,
                        scheme.name(),
                        u * lo / h,
                        t0.elapsed().as_secs_f64()
                    );
                    continue;
                }
                let mut hi = f64::NAN;
                let mut reason = String::new();
                // At least five full steps per trial: beyond that Δt says nothing about stability.
                let cap = scene.t_end / 5.0;
                // Doubling, the last try at the cap itself.
                while hi.is_nan() && lo < cap {
                    let next = (2.0 * lo).min(cap);
                    let (ok, why, _) = trial(&scene, scheme, next, refs);
                    trials += 1;
                    if ok {
                        lo = next;
                    } else {
                        hi = next;
                        reason = why;
                    }
                }
                if !hi.is_nan() {
                    for _ in 0..5 {
                        let mid = 0.5 * (lo + hi);
                        let (ok, why, _) = trial(&scene, scheme, mid, refs);
                        trials += 1;
                        if ok {
                            lo = mid;
                        } else {
                            hi = mid;
                            reason = why;
                        }
                    }
                }
                if hi.is_nan() {
                    reason = format!("stable up to the five-step cap T/5 = {cap:.3e}");
                }
                let wall = t0.elapsed().as_secs_f64();
                dgsph::say!(
                    "{name} {}: stable Δt {lo:.3e} (C = {:.3}), unstable {hi:.3e}: {reason} [{trials} trials, {wall:.0} s]",
                    scheme.name(),
                    u * lo / h
                );
                let unstable = if hi.is_nan() {
                    ("—".to_string(), "—".to_string())
                } else {
                    (format!("{hi:.3e}"), format!("{:.3}", u * hi / h))
                };
                let _ = writeln!(
                    md,
                    "| {name} | {dx} | {} | {} | {lo:.3e} | {:.3} | {} | {} | {} | {trials} | {wall:.0} |",
                    fluid + walls,
                    scheme.name(),
                    u * lo / h,
                    unstable.0,
                    unstable.1,
                    reason.replace('|', "\\|"),
                );
                lines[line].push((dx, lo));
                let _ = writeln!(
                    csv,
                    "{name},{dx},{},{lo},{},{hi},{},\"{}\"",
                    scheme.name(),
                    u * lo / h,
                    u * hi / h,
                    reason.replace('"', "'")
                );
            }
        }
        let name = session::scene_stem(path);
        for (line, scheme) in lines
            .into_iter()
            .zip(["euler", "predictor_corrector", "dg"])
        {
            map.push(Series::line(format!("{name} {scheme}"), line));
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))
        .map_err(AppError::Output)?;
    if args.dx.len() > 1
        && line_plot(
            &args.out.join("dt_limit.svg"),
            "largest stable time step",
            "dx",
            "stable Δt",
            &map,
            true,
        )
        .map_err(AppError::Output)?
    {
        md.push_str("\n![stable Δt against dx](dt_limit.svg)\n");
    }
    std::fs::create_dir_all(&args.out)
        .and_then(|()| dgsph::output::write_atomic(&args.out.join("dt_limit.md"), md.as_bytes()))
        .and_then(|()| dgsph::output::write_atomic(&args.out.join("dt_limit.csv"), csv.as_bytes()))
        .with_context(|| format!("writing into {}", args.out.display()))
        .map_err(AppError::Output)?;
    dgsph::say!("{}", args.out.join("dt_limit.md").display());
    Ok(exit::OK)
}
