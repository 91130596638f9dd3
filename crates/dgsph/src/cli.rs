//! The command-line tasks shared by `dgsph` and `cargo xtask` (`run`, `check`, `report`).

use crate::overrides::{Overrides, Preset};
use crate::session::{self, AppError, RunOptions, exit};
use std::path::PathBuf;

/// Flags of `dgsph run` (and `cargo xtask run`).
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// Output directory.
    #[arg(long, default_value = "target/runs")]
    pub out: PathBuf,
    /// `full` (the scene as written) or `quick` (its `[quick]` overrides).
    #[arg(long, value_enum, default_value = "full")]
    pub preset: Preset,
    /// Output-file prefix (default: the scene file's stem); files are `<tag>_<scheme>.*`.
    #[arg(long)]
    pub tag: Option<String>,
    /// Write `<out>/<tag>_<scheme>.checkpoint` every N steps (and at the end).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub checkpoint_every: Option<u64>,
    /// Continue every scheme from its checkpoint, appending to its records (an error if
    /// there is no checkpoint, or if it was written under other physics).
    #[arg(long)]
    pub resume: bool,
    /// Write ParaView frames (`<out>/<tag>_<scheme>.pvd` and `.vtp` files).
    #[arg(long)]
    pub vtk: bool,
    /// Records between particle frames (MCAP and ParaView).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub frame_every: Option<u64>,
    /// Seconds between progress lines when stderr is not a terminal (0: none).
    #[arg(long, default_value_t = 5.0, allow_negative_numbers = true)]
    pub progress_every: f64,
    /// Changes to the scene.
    #[command(flatten)]
    pub overrides: Overrides,
}

/// Flags of `dgsph check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The scene file (TOML).
    pub scene: PathBuf,
    /// `full` or `quick`.
    #[arg(long, value_enum, default_value = "full")]
    pub preset: Preset,
}

/// Flags of `dgsph report`.
#[derive(Debug, clap::Args)]
pub struct ReportArgs {
    /// The output directory of a run or validation.
    pub dir: PathBuf,
}

/// Starts the global rayon pool with `RAYON_NUM_THREADS` threads (unset, empty or 0: one per
/// core). A value that is not a count, or far more threads than the machine has cores (more
/// than 1024 and 16 per core), is bad input naming the variable, instead of a panic in the
/// pool when the threads cannot be started.
pub fn start_thread_pool() -> Result<(), AppError> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cap = (16 * cores).max(1024);
    let bad = |why: String| {
        AppError::Input(anyhow::anyhow!(
            "RAYON_NUM_THREADS: {why} (this machine has {cores} cores; unset it to use them all)"
        ))
    };
    let threads = match std::env::var("RAYON_NUM_THREADS") {
        Ok(v) if !v.trim().is_empty() => {
            let n: usize = v
                .trim()
                .parse()
                .map_err(|_| bad(format!("{v:?} is not a thread count")))?;
            if n > cap {
                return Err(bad(format!("{n} threads is more than {cap}")));
            }
            n
        }
        _ => 0,
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .map_err(|e| bad(format!("the thread pool could not start: {e}")))
}

/// `dgsph run`: runs a scene; returns the exit code.
pub fn run(args: &RunArgs) -> Result<u8, AppError> {
    let scene = session::load_scene(&args.scene)?;
    let scene = args.overrides.apply(args.preset.apply(&scene))?;
    let name = match &args.tag {
        Some(tag) => tag.clone(),
        None => {
            let stem = session::scene_stem(&args.scene);
            session::check_name(&stem).map_err(|e| {
                AppError::Input(anyhow::anyhow!(
                    "{e}; the scene file's name is the default: pass --tag NAME, or rename {}",
                    args.scene.display()
                ))
            })?;
            stem
        }
    };
    if !(args.progress_every.is_finite() && args.progress_every >= 0.0) {
        return Err(AppError::Input(anyhow::anyhow!(
            "--progress-every must be ≥ 0 seconds"
        )));
    }
    crate::say!(
        "{} ({} preset) → {}",
        args.scene.display(),
        args.preset.name(),
        args.out.display()
    );
    let outcome = session::run_scene(
        &scene,
        sph_cases::reference::References::embedded(),
        &RunOptions {
            out: args.out.clone(),
            name,
            checkpoint_every: args.checkpoint_every.map(|n| n as usize),
            resume: args.resume,
            vtk: args.vtk,
            frame_every: args.frame_every.map(|n| n as usize),
            progress_every: args.progress_every,
            verbose: true,
            stop: crate::signals::installed(),
        },
    )?;
    let passed = print_checks(&outcome.checks);
    Ok(if outcome.failed_runs > 0 {
        exit::RUN_FAILED
    } else if passed {
        exit::OK
    } else {
        exit::CHECKS_FAILED
    })
}

/// Prints the pass/fail table; returns true if every check passed.
pub fn print_checks(checks: &[sph_cases::Check]) -> bool {
    if checks.is_empty() {
        return true;
    }
    crate::say!(
        "\n{:<28} {:<52} {:>14} {:>22}  result",
        "case",
        "check",
        "value",
        "criterion"
    );
    for c in checks {
        crate::say!(
            "{:<28} {:<52} {:>14.6e} {:>22}  {}",
            c.case,
            c.name,
            c.value,
            c.criterion.describe(),
            c.outcome()
        );
    }
    let failed = checks.iter().filter(|c| c.fails()).count();
    let known = checks.iter().filter(|c| c.known_failure.is_some()).count();
    crate::say!(
        "\n{} checks: {} passed, {} failed{}",
        checks.len(),
        checks.iter().filter(|c| c.passed()).count(),
        failed,
        if known > 0 {
            format!(
                ", {} of {known} declared known failures failed as declared",
                checks
                    .iter()
                    .filter(|c| c.known_failure.is_some() && !c.passed())
                    .count()
            )
        } else {
            String::new()
        }
    );
    failed == 0
}

/// `dgsph check`: validates a scene and prints what it would run.
pub fn check(args: &CheckArgs) -> Result<u8, AppError> {
    let scene = args.preset.apply(&session::load_scene(&args.scene)?);
    scene
        .validate(&args.scene.display().to_string())
        .map_err(|e| AppError::Input(e.into()))?;
    let e = scene.estimate();
    let (fluid, walls, carved) =
        sph_cases::registry::particle_counts(&scene, sph_cases::reference::References::embedded())
            .map_err(|e| AppError::Input(e.into()))?;
    let n = (fluid + walls) as f64;
    let (steps, rest) = scene.steps();
    let mut effects = Vec::new();
    if let Some(g) = scene.effects.gravity {
        effects.push(format!("gravity {g:?}"));
    }
    if let Some(v) = scene.effects.viscosity {
        effects.push(format!("viscosity ν = {}", v.nu));
    }
    if let Some(c) = &scene.cavity {
        effects.push(format!(
            "viscosity ν = {} (Re {})",
            c.lid_speed.abs() / c.reynolds,
            c.reynolds
        ));
    }
    if let Some(s) = scene.effects.shifting {
        effects.push(format!("shifting A = {}", s.coefficient));
    }
    if let Some(hv) = scene.hyperviscosity() {
        effects.push(format!(
            "hyperviscosity C = {:.4} m/s{}",
            hv.speed,
            match hv.region {
                sph_integrators::HyperviscousRegion::Everywhere => "",
                sph_integrators::HyperviscousRegion::PositivePressure => " where p > 0",
            }
        ));
    }
    if let Some(f) = scene.sim_config().free_surface {
        effects.push(format!(
            "free surface (∇·r < {}{}; p = 0 {})",
            f.div_r_threshold,
            if f.scan { ", or an empty umbrella" } else { "" },
            if f.zero_pressure_depth > 0.0 && f.measured_depth {
                "outside the surface particles, as deep as their truncation says"
            } else if f.zero_pressure_depth > 0.0 {
                "half a spacing outside the surface particles"
            } else {
                "at the surface particles"
            }
        ));
    }
    if walls > 0 {
        effects.push(format!("walls ({walls} particles)"));
    }
    if let Some(p) = scene.periodic_axes() {
        let axes: Vec<&str> = ["x", "y", "z"]
            .iter()
            .zip(p.axes)
            .filter(|(_, a)| *a)
            .map(|(n, _)| *n)
            .collect();
        effects.push(format!("periodic {}", axes.join(", ")));
    }
    let bytes = n * e.bytes / e.particles().max(1.0);
    crate::say!(
        "{}: valid ({} preset)",
        args.scene.display(),
        args.preset.name()
    );
    crate::say!(
        "  case        {} ({}D), schemes {}",
        scene.case.name(),
        scene.dim,
        scene
            .schemes
            .iter()
            .map(|s| s.name())
            .collect::<Vec<_>>()
            .join(", ")
    );
    crate::say!(
        "  particles   {fluid} fluid + {walls} wall = {}{}",
        fluid + walls,
        if carved > 0 {
            format!(" ({carved} fluid lattice sites inside walls left out)")
        } else {
            String::new()
        }
    );
    crate::say!(
        "  kernel      {}, h = {} (dx = {}), about {:.0} neighbours each",
        scene.kernel.name(),
        scene.h(),
        scene.dx,
        e.neighbors
    );
    crate::say!(
        "  memory      about {:.2} GiB per run (limit {:.2} GiB)",
        bytes / (1u64 << 30) as f64,
        scene.limits.memory_bytes() / (1u64 << 30) as f64
    );
    crate::say!(
        "  steps       {} of dt = {} to t = {}{} per scheme",
        steps + usize::from(rest.is_some()),
        scene.dt,
        scene.t_end,
        if rest.is_some() {
            " (the last one shorter)"
        } else {
            ""
        }
    );
    crate::say!(
        "  effects     {}",
        if effects.is_empty() {
            "none".to_string()
        } else {
            effects.join("; ")
        }
    );
    let config = scene.sim_config();
    crate::say!(
        "  operators   {} pressure gradient, {}renormalised, {} Laplacian{}{}, DG Hessian {}",
        match config.gradient {
            sph_operators::GradientForm::Difference => "difference Σ V_j (p_j − p_i) ∇W_ij",
            sph_operators::GradientForm::Symmetric => "symmetric Σ V_j (p_i + p_j) ∇W_ij",
            sph_operators::GradientForm::Adjoint => "adjoint Σ V_j (p_i L_i + p_j L_j) ∇W_ij",
        },
        if config.renormalise { "" } else { "not " },
        if config.consistent_laplacian {
            "linear-consistent"
        } else {
            "Morris"
        },
        if config.level_consistent {
            " + the gradient's level term D(p c/ρ), c = 2 Σ V_j ∇W_ij"
        } else {
            ""
        },
        if config.normalised_gradient {
            ", gradient divided by ∇·r/D away from the free surface"
        } else {
            ""
        },
        match config.dg_hessian {
            sph_operators::HessianForm::Eq25 => "eq25",
            sph_operators::HessianForm::QuadraticFit => "quadratic_fit",
        }
    );
    if config.density_relaxation > 0.0 {
        crate::say!(
            "  density     relaxed towards the lattice's by {} of its error per step ({} form)",
            config.density_relaxation,
            match config.density_relaxation_form {
                sph_integrators::DensityRelaxationForm::Velocity => "velocity",
                sph_integrators::DensityRelaxationForm::Position => "position",
            }
        );
    }
    crate::say!(
        "  solver      {} (tolerance {:e})",
        scene.solver.name(),
        scene.sim_config().solve.rel_tolerance
    );
    let d = scene.diagnostics();
    crate::say!(
        "  diagnostics {}",
        match (d.det_f, d.div_u) {
            (false, false) => "none".to_string(),
            (a, b) => [("det_f", a), ("div_u", b)]
                .iter()
                .filter(|x| x.1)
                .map(|x| x.0)
                .collect::<Vec<_>>()
                .join(", "),
        }
    );
    if !scene.check.is_empty() {
        for c in &scene.check {
            crate::say!(
                "  check       {} {}{}",
                c.quantity,
                c.min.map_or(String::new(), |m| format!("≥ {m} ")),
                c.max.map_or(String::new(), |m| format!("≤ {m}"))
            );
        }
    }
    Ok(exit::OK)
}
