//! `cargo xtask dt-limit`: the largest stable time step of each scheme, by bisection on the
//! CFL number `C = U Δt / h` (`U`: the run's velocity scale, see `max_speed_ratio`), for the
//! elliptical drop, the Re 400 cavity and the dam break (their quick sizes unless `--preset
//! full`).
//!
//! A trial runs the scene with the trial `Δt` to a fixed end time and is **stable** when it
//! reaches the end with no failed step (non-finite values, a solver that does not converge, a
//! particle escaping the walls), no wall penetration, and speeds bounded by three times the
//! velocity scale. The displacement limit of blow-up detection is raised to 10 h for these
//! trials, so it does not cap `Δt` by itself. A start that is unstable is halved (at most five
//! times); from a stable one the search doubles `Δt` (the last doubling clipped to the cap
//! below) until a trial is unstable, then bisects five times: the result brackets the limit to
//! within 1/32 of the first unstable step. A trial has at least five full steps: when
//! `Δt = T/5` is still stable the table says so ("stable up to the five-step cap") instead of
//! giving an unstable step. Writes `dt_limit.md` and `dt_limit.csv` into `--out`.
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

/// One trial: stable, or why not.
fn trial(scene: &Scene, scheme: SchemeKind, dt: f64, refs: &References) -> Result<(), String> {
    let mut s = scene.clone();
    s.dt = dt;
    // A trial is a fixed step: the automatic one would only be bounded by it.
    s.time_step.auto = Some(false);
    s.schemes = vec![scheme];
    s.limits.max_displacement = Some(10.0);
    s.output.sample_every = Some(1);
    let mut sink = MemorySink::default();
    let r = registry::run_scheme(&s, scheme, refs, RunControl::default(), &mut sink)
        .map_err(|e| format!("setup: {e}"))?;
    let get = |k: &str| r.results.get(k).copied().unwrap_or(f64::NAN);
    if let Some(e) = &r.failure {
        Err(first_words(&e.to_string()))
    } else if get("max_wall_penetrations") > 0.0 {
        Err("wall penetration".into())
    } else if get("max_speed_ratio").is_nan() || get("max_speed_ratio") > 3.0 {
        Err(format!("max |u|/U = {:.2}", get("max_speed_ratio")))
    } else {
        Ok(())
    }
}

/// What one scheme's search found: `lo` the largest stable step (the last unstable start
/// when no start was stable), `hi` the smallest unstable one (NaN when none was met).
struct Bracket {
    lo: f64,
    hi: f64,
    /// Why `hi` (or the last start) was unstable.
    reason: String,
    trials: usize,
    /// Whether a start (the scene's step or one of its five halvings) was stable.
    found: bool,
}

/// The search of the module docs: halve an unstable `start` up to five times, double (the last
/// try at `cap` itself) until a step is unstable, then bisect five times. `test` is one trial.
fn bracket(start: f64, cap: f64, mut test: impl FnMut(f64) -> Result<(), String>) -> Bracket {
    let mut b = Bracket {
        lo: start,
        hi: f64::NAN,
        reason: String::new(),
        trials: 0,
        found: false,
    };
    let mut try_at = |b: &mut Bracket, dt: f64| {
        b.trials += 1;
        match test(dt) {
            Ok(()) => {
                b.lo = dt;
                true
            }
            Err(why) => {
                b.hi = dt;
                b.reason = why;
                false
            }
        }
    };
    let mut dt = start;
    for _ in 0..6 {
        if try_at(&mut b, dt) {
            b.found = true;
            break;
        }
        dt *= 0.5;
    }
    if !b.found {
        b.lo = b.hi;
        return b;
    }
    // A start that failed is the first unstable step already.
    while b.hi.is_nan() && b.lo < cap {
        let next = (2.0 * b.lo).min(cap);
        try_at(&mut b, next);
    }
    if !b.hi.is_nan() {
        for _ in 0..5 {
            let mid = 0.5 * (b.lo + b.hi);
            try_at(&mut b, mid);
        }
    }
    b
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
                // At least five full steps per trial: beyond that Δt says nothing about stability.
                let cap = scene.t_end / 5.0;
                let Bracket {
                    lo,
                    hi,
                    mut reason,
                    trials,
                    found,
                } = bracket(scene.dt, cap, |dt| trial(&scene, scheme, dt, refs));
                if !found {
                    let _ = writeln!(
                        md,
                        "| {name} | {dx} | {} | {} | — | — | {lo:.3e} | {:.3} | {reason} (at 1/32 of the scene's Δt) | {trials} | {:.0} |",
                        fluid + walls,
                        scheme.name(),
                        u * lo / h,
                        t0.elapsed().as_secs_f64()
                    );
                    continue;
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

#[cfg(test)]
mod tests {
    use super::bracket;

    /// A synthetic stability limit: steps up to `limit` are stable.
    fn limited(limit: f64) -> impl FnMut(f64) -> Result<(), String> {
        move |dt| {
            if dt <= limit {
                Ok(())
            } else {
                Err(format!("{dt} > {limit}"))
            }
        }
    }

    #[test]
    fn the_search_brackets_the_limit_from_a_stable_and_an_unstable_start() {
        for (start, trials) in [(0.1, 8), (1.0, 8)] {
            let b = bracket(start, 100.0, limited(0.37));
            assert!(b.found);
            assert!(b.lo <= 0.37 && b.hi > 0.37, "{start}: {} {}", b.lo, b.hi);
            // Five bisections of a doubling interval: within 1/32 of the unstable step.
            assert!(
                b.hi - b.lo <= b.hi / 32.0 + 1e-15,
                "{start}: {} {}",
                b.lo,
                b.hi
            );
            assert_eq!(b.reason, format!("{} > 0.37", b.hi));
            // From 0.1: 0.1, 0.2, 0.4, five bisections. From 1.0: 1.0, 0.5, 0.25, five
            // bisections (0.5, already unstable, is not tried again).
            assert_eq!(b.trials, trials, "{start}");
        }
    }

    #[test]
    fn the_search_tries_the_cap_and_gives_up_after_five_halvings() {
        let b = bracket(0.3, 1.0, limited(5.0));
        assert!(b.found && b.hi.is_nan());
        assert_eq!(b.lo, 1.0, "the cap itself is tried");
        assert_eq!(b.trials, 3, "0.3, 0.6, 1.0");
        let b = bracket(1.0, 10.0, limited(0.001));
        assert!(!b.found);
        assert_eq!(b.trials, 6);
        assert_eq!(b.lo, 1.0 / 32.0, "the last start tried");
        assert_eq!(b.reason, format!("{} > 0.001", 1.0 / 32.0));
    }
}
