//! Running a scene: every scheme of it, with its files, checkpoints, resume rule, progress and
//! run summary. Shared by `dgsph run` and `cargo xtask validate`.

use crate::output::{FileOptions, RunFiles, checkpoint_path};
use crate::summary::{PhaseRecord, RunRecord, SCHEMA_VERSION, finite};
use anyhow::Context;
use serde::{Deserialize, Serialize};
use sph_cases::reference::References;
use sph_cases::run::{RunControl, SchemeRun};
use sph_cases::{CaseError, Check, Scene, registry};
use sph_integrators::{Checkpoint, Phase, SchemeKind};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Why a command failed, by the exit code it maps to.
#[derive(Debug)]
pub enum AppError {
    /// Bad input: a malformed or invalid scene, a bad flag, an unusable checkpoint (exit 2).
    Input(anyhow::Error),
    /// A run the command started failed, and the command stopped there (exit 3).
    Run(anyhow::Error),
    /// Results could not be written (exit 4).
    Output(anyhow::Error),
}

impl std::fmt::Display for AppError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AppError::Input(e) | AppError::Run(e) => write!(f, "{e:#}"),
            AppError::Output(e) => write!(f, "writing results: {e:#}"),
        }
    }
}

impl std::error::Error for AppError {}

impl AppError {
    /// The exit code this error maps to ([`exit`]).
    pub fn exit_code(&self) -> u8 {
        match self {
            AppError::Input(_) => exit::BAD_INPUT,
            AppError::Run(_) => exit::RUN_FAILED,
            AppError::Output(_) => exit::OUTPUT_FAILED,
        }
    }
}

/// Exit codes of `dgsph` and `cargo xtask validate`.
pub mod exit {
    /// Every run completed and every check passed.
    pub const OK: u8 = 0;
    /// A check failed.
    pub const CHECKS_FAILED: u8 = 1;
    /// Bad input (scene, flags, checkpoint).
    pub const BAD_INPUT: u8 = 2;
    /// A run stopped at a failed step (blow-up, solver failure, non-finite values).
    pub const RUN_FAILED: u8 = 3;
    /// Results could not be written.
    pub const OUTPUT_FAILED: u8 = 4;
}

/// How to run a scene.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Output directory.
    pub out: PathBuf,
    /// Output prefix: files are `<name>_<scheme>.*`.
    pub name: String,
    /// Write a checkpoint every this many steps (and at the end).
    pub checkpoint_every: Option<usize>,
    /// Continue every scheme from its checkpoint (an error when there is none).
    pub resume: bool,
    /// Write ParaView frames (also when the scene's `[output] vtk` says so).
    pub vtk: bool,
    /// Records between particle frames (overrides the scene's `[output] frame_every`).
    pub frame_every: Option<usize>,
    /// Seconds between progress lines when stderr is not a terminal (0: none).
    pub progress_every: f64,
    /// Print a line per scheme and its pass breakdown.
    pub verbose: bool,
}

/// What running a scene produced.
#[derive(Debug, Default)]
pub struct SceneOutcome {
    /// Checks of every scheme and across schemes.
    pub checks: Vec<Check>,
    /// One record per scheme run.
    pub runs: Vec<RunRecord>,
    /// Runs that stopped at a failed step.
    pub failed_runs: usize,
    /// Of those, the runs the scene did not declare a known failure (its `completed` check).
    pub unexpected_failed_runs: usize,
    /// Wall time of the scene.
    pub wall_s: f64,
}

/// What a checkpoint records about the run it belongs to.
#[derive(Debug, Serialize, Deserialize)]
pub struct CheckpointMeta {
    /// dgsph version that wrote it.
    pub dgsph: String,
    /// Case kind.
    pub case: String,
    /// Scheme.
    pub scheme: String,
    /// The scene as run (JSON).
    pub scene: Scene,
}

/// A valid output-name prefix: letters, digits, `_`, `-`, `.`; not starting with `.`; no path
/// separators (so a `--tag` cannot write outside the output directory).
pub fn check_name(name: &str) -> Result<(), AppError> {
    let ok = !name.is_empty()
        && !name.starts_with('.')
        && name.len() <= 128
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
    if ok {
        Ok(())
    } else {
        Err(AppError::Input(anyhow::anyhow!(
            "output name {name:?} must be 1–128 letters, digits, '_', '-' or '.', not starting \
             with '.' (it prefixes files in the output directory)"
        )))
    }
}

/// Reads, parses and validates a scene file (schema, values, case rules).
pub fn load_scene(path: &Path) -> Result<Scene, AppError> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading scene {}", path.display()))
        .map_err(AppError::Input)?;
    registry::parse_scene(&path.display().to_string(), &text).map_err(|e| AppError::Input(e.into()))
}

/// The file stem of a scene path (the default output prefix).
pub fn scene_stem(path: &Path) -> String {
    path.file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
}

fn read_checkpoint(path: &Path, scene: &Scene, scheme: SchemeKind) -> Result<Checkpoint, AppError> {
    let input = |e: anyhow::Error| AppError::Input(e);
    if !path.exists() {
        return Err(input(anyhow::anyhow!(
            "--resume: no checkpoint at {} (run without --resume to start, with \
             --checkpoint-every N to write checkpoints)",
            path.display()
        )));
    }
    let bytes = std::fs::read(path)
        .with_context(|| format!("reading {}", path.display()))
        .map_err(input)?;
    let c = Checkpoint::decode(&bytes)
        .with_context(|| format!("checkpoint {}", path.display()))
        .map_err(input)?;
    let meta: CheckpointMeta = serde_json::from_str(&c.meta)
        .with_context(|| format!("checkpoint {}: its record of the run", path.display()))
        .map_err(input)?;
    if meta.scheme != scheme.name() || meta.case != scene.case.name() {
        return Err(input(anyhow::anyhow!(
            "checkpoint {} belongs to a {} run of {}, not {} of {}",
            path.display(),
            meta.scheme,
            meta.case,
            scheme.name(),
            scene.case.name()
        )));
    }
    let differs = scene.resume_differences(&meta.scene);
    if !differs.is_empty() {
        return Err(input(anyhow::anyhow!(
            "checkpoint {} was written under another scene ({} differs); resuming would change \
             the physics mid-run",
            path.display(),
            differs.join(", ")
        )));
    }
    Ok(c)
}

fn phases(run: &SchemeRun) -> std::collections::BTreeMap<String, PhaseRecord> {
    Phase::ALL
        .iter()
        .filter(|p| run.phases.ran(**p))
        .map(|p| {
            (
                p.name().to_string(),
                PhaseRecord {
                    seconds: run.phases.seconds(*p),
                    runs: u64::from(run.phases.runs(*p)),
                },
            )
        })
        .collect()
}

/// The pass breakdown of a run as text lines (seconds, share of the step time, runs per step).
pub fn breakdown(run: &SchemeRun) -> String {
    let total: f64 = Phase::ALL.iter().map(|p| run.phases.seconds(*p)).sum();
    let steps = run.steps_taken.max(1) as f64;
    let mut s = String::new();
    for p in Phase::ALL.iter().filter(|p| run.phases.ran(**p)) {
        let sec = run.phases.seconds(*p);
        s.push_str(&format!(
            "      {:<16} {:>9.3} s {:>5.1} %  {:>8.2e} s/step  {:.2} runs/step\n",
            p.name(),
            sec,
            100.0 * sec / total.max(1e-300),
            sec / steps,
            f64::from(run.phases.runs(*p)) / steps
        ));
    }
    let absent: Vec<&str> = Phase::ALL
        .iter()
        .filter(|p| !run.phases.ran(**p))
        .map(|p| p.name())
        .collect();
    if !absent.is_empty() && run.steps_taken > 0 {
        s.push_str(&format!("      not run: {}\n", absent.join(", ")));
    }
    s
}

/// Runs every scheme of `scene` (already preset-adjusted) into `opts.out`.
pub fn run_scene(
    scene: &Scene,
    refs: &References,
    opts: &RunOptions,
) -> Result<SceneOutcome, AppError> {
    check_name(&opts.name)?;
    let t0 = Instant::now();
    std::fs::create_dir_all(&opts.out)
        .with_context(|| format!("creating {}", opts.out.display()))
        .map_err(AppError::Output)?;
    let mut scene = scene.clone();
    if let Some(f) = opts.frame_every {
        scene.output.frame_every = Some(f);
    }
    let mut outcome = SceneOutcome::default();
    let mut results = Vec::new();
    for &scheme in &scene.schemes {
        let run = format!("{}_{}", opts.name, scheme.name());
        let cpath = checkpoint_path(&opts.out, &run);
        let resume = if opts.resume {
            let c = read_checkpoint(&cpath, &scene, scheme)?;
            if opts.verbose {
                println!(
                    "  {run}: resuming from step {} (t = {}) in {}",
                    c.step,
                    c.t,
                    cpath.display()
                );
            }
            Some(c)
        } else {
            None
        };
        let meta = CheckpointMeta {
            dgsph: env!("CARGO_PKG_VERSION").to_string(),
            case: scene.case.name().to_string(),
            scheme: scheme.name().to_string(),
            scene: scene.clone(),
        };
        let meta_json = serde_json::to_string(&meta)
            .context("recording the scene")
            .map_err(AppError::Output)?;
        let mut metadata = std::collections::BTreeMap::new();
        metadata.insert("case".to_string(), scene.case.name().to_string());
        metadata.insert("scheme".to_string(), scheme.name().to_string());
        metadata.insert("dim".to_string(), scene.dim.to_string());
        metadata.insert(
            "scene".to_string(),
            serde_json::to_string(&scene).unwrap_or_default(),
        );
        let mut files = RunFiles::new(
            &opts.out,
            &run,
            FileOptions {
                resume_step: resume.as_ref().map(|c| c.step),
                vtk: opts.vtk || scene.output.vtk,
                progress_every: opts.progress_every,
                metadata,
            },
        );
        let control = RunControl {
            resume: resume.as_ref(),
            checkpoint_every: opts.checkpoint_every,
            checkpoint_meta: meta_json,
        };
        let result = registry::run_scheme(&scene, scheme, refs, control, &mut files);
        let finished = files.finish();
        let r = match result {
            Ok(r) => r,
            Err(CaseError::Output(e)) => {
                return Err(AppError::Output(
                    anyhow::Error::from(e).context(format!("run {run}")),
                ));
            }
            Err(
                e @ (CaseError::Measure { .. } | CaseError::Step { .. } | CaseError::Settle(_)),
            ) => {
                eprintln!(
                    "  {run}: FAILED: {e} (rows so far in {})",
                    files.csv_path().display()
                );
                outcome.failed_runs += 1;
                let check =
                    sph_cases::run::run_completes_check(&scene, scheme, &run, &e.to_string());
                outcome.unexpected_failed_runs += usize::from(check.known_failure.is_none());
                outcome.checks.push(check);
                continue;
            }
            Err(e) => {
                return Err(AppError::Input(
                    anyhow::Error::from(e).context(format!("run {run}")),
                ));
            }
        };
        finished.map_err(AppError::Output)?;
        if let Some(e) = &r.failure {
            outcome.failed_runs += 1;
            outcome.unexpected_failed_runs += usize::from(
                sph_cases::run::run_completes_check(&scene, scheme, &run, "")
                    .known_failure
                    .is_none(),
            );
            eprintln!(
                "  {run}: FAILED: {e} (rows so far in {})",
                files.csv_path().display()
            );
        }
        let record = RunRecord {
            schema_version: SCHEMA_VERSION,
            case: scene.case.name().to_string(),
            name: opts.name.clone(),
            scheme: scheme.name().to_string(),
            kernel: scene.kernel.name().to_string(),
            solver: scene.solver.name().to_string(),
            dim: scene.dim,
            dx: scene.dx,
            dt: scene.dt,
            fluid: r.particles.0,
            walls: r.particles.1,
            steps: r.steps_taken,
            step: r.step,
            t: r.t,
            wall_s: r.wall_s,
            solver_iters_mean: r
                .results
                .get("solver_iterations_mean")
                .copied()
                .unwrap_or(0.0),
            status: r
                .failure
                .as_ref()
                .map_or("completed".to_string(), |e| format!("failed: {e}")),
            results: r
                .results
                .iter()
                .map(|(k, v)| (k.clone(), finite(*v)))
                .collect(),
            phases: phases(&r),
        };
        let json = serde_json::to_vec_pretty(&record)
            .context("encoding the run record")
            .map_err(AppError::Output)?;
        let path = opts.out.join(format!("{run}.run.json"));
        crate::output::write_atomic(&path, &json)
            .with_context(|| format!("writing {}", path.display()))
            .map_err(AppError::Output)?;
        if opts.verbose {
            let n = (r.particles.0 + r.particles.1) as f64;
            let per_step = r.wall_s / r.steps_taken.max(1) as f64;
            println!(
                "  {run:<36} fluid={} walls={}{} steps={} t={:.4} iters/step {:.1}  {:.4} s/step  {:.3e} particle-steps/s  [{:.1} s]  {}",
                r.particles.0,
                r.particles.1,
                if r.carved > 0 {
                    format!(" (carved {})", r.carved)
                } else {
                    String::new()
                },
                r.steps_taken,
                r.t,
                record.solver_iters_mean,
                per_step,
                n / per_step,
                r.wall_s,
                record.status
            );
            let key: Vec<String> = registry::case_results(scene.case)
                .iter()
                .filter_map(|k| r.results.get(*k).map(|v| format!("{k} {v:.4e}")))
                .chain(
                    [
                        "max_wall_penetrations",
                        "max_wall_intrusion_dx",
                        "wall_guarded",
                    ]
                    .iter()
                    .filter(|_| r.particles.1 > 0)
                    .filter_map(|k| r.results.get(*k).map(|v| format!("{k} {v}"))),
                )
                .collect();
            if !key.is_empty() {
                println!("      {}", key.join("  "));
            }
            print!("{}", breakdown(&r));
        }
        outcome.checks.extend(r.checks.iter().cloned().map(|mut c| {
            c.case = format!("{}/{}", c.case, opts.name);
            c
        }));
        outcome.runs.push(record);
        results.push((scheme, r.results));
    }
    let refs_by_scheme: Vec<(SchemeKind, &sph_cases::Results)> =
        results.iter().map(|(s, r)| (*s, r)).collect();
    outcome.checks.extend(
        registry::scene_checks(&scene, &refs_by_scheme)
            .into_iter()
            .map(|mut c| {
                c.case = format!("{}/{}", c.case, opts.name);
                c
            }),
    );
    outcome.wall_s = t0.elapsed().as_secs_f64();
    Ok(outcome)
}
