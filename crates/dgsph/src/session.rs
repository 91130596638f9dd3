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
    /// A signal stopped the run after a step; its checkpoint and `run.json` are written
    /// (exit `code`: 128 + the signal's number).
    Interrupted {
        /// What was stopped and how to continue.
        message: String,
        /// The exit code.
        code: u8,
    },
}

impl std::fmt::Display for AppError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AppError::Input(e) | AppError::Run(e) => write!(f, "{e:#}"),
            AppError::Output(e) => write!(f, "writing results: {e:#}"),
            AppError::Interrupted { message, .. } => write!(f, "{message}"),
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
            AppError::Interrupted { code, .. } => *code,
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
    /// SIGINT stopped the run after a step (checkpoint and `run.json` written; `--resume`
    /// continues it). SIGTERM: 143.
    pub const INTERRUPTED: u8 = 130;
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
    /// Stop after the step in progress when this is set (SIGINT, SIGTERM).
    pub stop: Option<crate::signals::Stop>,
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

impl SceneOutcome {
    /// Counts a run that stopped at a failed step, and whether the scene declared that.
    fn count_failed(&mut self, scene: &Scene, scheme: SchemeKind, run: &str) {
        self.failed_runs += 1;
        self.unexpected_failed_runs += usize::from(
            sph_cases::run::run_completes_check(scene, scheme, run, "")
                .known_failure
                .is_none(),
        );
    }
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
    /// What the scene's numerics resolved to in the build that wrote it
    /// ([`Scene::resolved_numerics`]); absent in checkpoints of builds before it was recorded.
    #[serde(default)]
    pub numerics: Option<String>,
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
    let numerics = scene.resolved_numerics();
    match &meta.numerics {
        Some(n) if *n == numerics => Ok(c),
        Some(n) => Err(input(anyhow::anyhow!(
            "checkpoint {} was written by a dgsph that resolves this scene's numerics otherwise \
             (a default changed: {}); resuming would change the physics mid-run, so run it from \
             the start",
            path.display(),
            first_difference(n, &numerics)
        ))),
        None => Err(input(anyhow::anyhow!(
            "checkpoint {} was written by a dgsph ({}) that did not record its resolved numerics; \
             the flow scenes' defaults may have changed since, and resuming could change the \
             physics mid-run, so run it from the start",
            path.display(),
            meta.dgsph
        ))),
    }
}

/// Where two resolved-numerics texts first differ: the field of each around it.
fn first_difference(written: &str, now: &str) -> String {
    let field = |s: &str, at: usize| -> String {
        let start = s[..at].rfind([',', '{', ';']).map_or(0, |k| k + 1);
        let end = s[at..].find([',', '}', ';']).map_or(s.len(), |k| at + k);
        s[start..end].trim().chars().take(120).collect()
    };
    let at = written
        .char_indices()
        .zip(now.chars())
        .find(|((_, a), b)| a != b)
        .map_or(written.len().min(now.len()), |((k, _), _)| k);
    let at = (0..=at)
        .rev()
        .find(|&k| written.is_char_boundary(k) && now.is_char_boundary(k))
        .unwrap_or(0);
    format!(
        "written \"{}\", now \"{}\"",
        field(written, at),
        field(now, at)
    )
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
    let steps = run.segment_steps.max(1) as f64;
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
    if !absent.is_empty() && run.segment_steps > 0 {
        s.push_str(&format!("      not run: {}\n", absent.join(", ")));
    }
    s
}

/// Where a scheme of a resumed scene starts, from what an earlier run of it left in the output
/// directory (`<run>.run.json` exists exactly when the scheme's run ended: completed, failed or
/// interrupted).
enum Start {
    /// From t = 0 (not started before, or stopped before its first checkpoint).
    Fresh,
    /// From its checkpoint (interrupted, killed, or completed to an earlier end time).
    From(Box<Checkpoint>),
    /// Finished: completed to this scene's end, or stopped at a failed step. Left as it is.
    Finished(Box<RunRecord>),
}

/// The step count of `scene`'s run (a shorter last step included).
fn last_step(scene: &Scene) -> usize {
    let (full, rest) = scene.steps();
    full + usize::from(rest.is_some())
}

fn read_record(path: &Path) -> Result<RunRecord, AppError> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading {}", path.display()))
        .map_err(AppError::Input)?;
    serde_json::from_str(&text)
        .with_context(|| {
            format!(
                "--resume: {} is not a run record (delete it to run that scheme again)",
                path.display()
            )
        })
        .map_err(AppError::Input)
}

/// Where `scheme` resumes (see [`Start`]).
fn resume_start(
    scene: &Scene,
    scheme: SchemeKind,
    record: &Path,
    checkpoint: &Path,
) -> Result<Start, AppError> {
    if record.exists() {
        let r = read_record(record)?;
        let extend = r.status == "completed" && r.step < last_step(scene);
        if r.status != "interrupted" && !extend {
            // Its checkpoint, where there is one, must be of this scene.
            if checkpoint.exists() {
                read_checkpoint(checkpoint, scene, scheme)?;
            }
            return Ok(Start::Finished(Box::new(r)));
        }
    } else if !checkpoint.exists() {
        return Ok(Start::Fresh);
    }
    read_checkpoint(checkpoint, scene, scheme).map(|c| Start::From(Box::new(c)))
}

/// Holds `<out>/.dgsph.lock` for the life of the returned file: a second run into the same
/// directory is refused instead of interleaving its files with this one's. The lock goes with
/// the process (also when it is killed).
fn lock_output(out: &Path) -> Result<std::fs::File, AppError> {
    let path = out.join(".dgsph.lock");
    let file = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .with_context(|| format!("creating the lock {}", path.display()))
        .map_err(AppError::Output)?;
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(AppError::Input(anyhow::anyhow!(
            "output directory {} is in use by another dgsph run (it holds {}); wait for that \
             run or choose another --out",
            out.display(),
            path.display()
        ))),
        Err(std::fs::TryLockError::Error(e)) => Err(AppError::Output(
            anyhow::Error::from(e).context(format!("locking {}", path.display())),
        )),
    }
}

/// The run record of a finished run, its results as numbers again (`null` → NaN).
fn recorded_results(r: &RunRecord) -> sph_cases::Results {
    r.results
        .iter()
        .map(|(k, v)| (k.clone(), v.unwrap_or(f64::NAN)))
        .collect()
}

/// Runs every scheme of `scene` (already preset-adjusted) into `opts.out`. With
/// `opts.resume`, a scheme that finished is left as it is (its record and checks read back), an
/// interrupted one continues from its checkpoint, one never started starts; when every scheme
/// had finished nothing runs.
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
    let _lock = lock_output(&opts.out)?;
    let mut scene = scene.clone();
    if let Some(f) = opts.frame_every {
        scene.output.frame_every = Some(f);
    }
    let run_name = |scheme: SchemeKind| format!("{}_{}", opts.name, scheme.name());
    let record_path = |run: &str| opts.out.join(format!("{run}.run.json"));
    // Where each scheme starts, decided before anything runs: an unusable checkpoint stops the
    // command before it has changed a file.
    let starts = scene
        .schemes
        .iter()
        .map(|&scheme| {
            let run = run_name(scheme);
            if opts.resume {
                resume_start(
                    &scene,
                    scheme,
                    &record_path(&run),
                    &checkpoint_path(&opts.out, &run),
                )
            } else {
                Ok(Start::Fresh)
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    if opts.resume && starts.iter().all(|s| matches!(s, Start::Fresh)) {
        return Err(AppError::Input(anyhow::anyhow!(
            "--resume: nothing of {} to resume in {}: no checkpoint ({}) and no run record (run \
             without --resume to start, with --checkpoint-every N to write checkpoints)",
            opts.name,
            opts.out.display(),
            checkpoint_path(&opts.out, &run_name(scene.schemes[0])).display()
        )));
    }
    if opts.resume && starts.iter().all(|s| matches!(s, Start::Finished(_))) && opts.verbose {
        crate::say!(
            "  nothing to resume: every scheme of {} in {} has finished",
            opts.name,
            opts.out.display()
        );
    }
    let mut outcome = SceneOutcome::default();
    let mut results = Vec::new();
    for (&scheme, start) in scene.schemes.iter().zip(starts) {
        let run = run_name(scheme);
        let cpath = checkpoint_path(&opts.out, &run);
        let rpath = record_path(&run);
        let resume = match start {
            Start::Finished(record) => {
                if opts.verbose {
                    crate::say!(
                        "  {run}: finished earlier ({} at t = {}); left as it is",
                        record.status,
                        record.t
                    );
                }
                let values = recorded_results(&record);
                let failure = record.status.strip_prefix("failed: ");
                let checks = registry::run_checks(&scene, scheme, refs, &values, record.t, failure);
                if failure.is_some() {
                    outcome.count_failed(&scene, scheme, &run);
                }
                outcome.checks.extend(checks.into_iter().map(|mut c| {
                    c.case = format!("{}/{}", c.case, opts.name);
                    c
                }));
                outcome.runs.push(*record);
                results.push((scheme, values));
                continue;
            }
            Start::From(c) => {
                if opts.verbose {
                    crate::say!(
                        "  {run}: resuming from step {} (t = {}) in {}",
                        c.step,
                        c.t,
                        cpath.display()
                    );
                }
                Some(c)
            }
            Start::Fresh => {
                if opts.resume && opts.verbose {
                    crate::say!("  {run}: no checkpoint; starting at t = 0");
                }
                // A checkpoint of an earlier run in this directory must not be resumed as
                // this run's.
                if cpath.exists() {
                    std::fs::remove_file(&cpath)
                        .with_context(|| format!("removing {}", cpath.display()))
                        .map_err(AppError::Output)?;
                }
                None
            }
        };
        // The record is written when the run ends; until then there is none.
        if rpath.exists() {
            std::fs::remove_file(&rpath)
                .with_context(|| format!("removing {}", rpath.display()))
                .map_err(AppError::Output)?;
        }
        let meta = CheckpointMeta {
            dgsph: env!("CARGO_PKG_VERSION").to_string(),
            case: scene.case.name().to_string(),
            scheme: scheme.name().to_string(),
            scene: scene.clone(),
            numerics: Some(scene.resolved_numerics()),
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
            resume: resume.as_deref(),
            checkpoint_every: opts.checkpoint_every,
            checkpoint_meta: meta_json,
            stop: opts.stop.as_ref().map(|s| s.flag.as_ref()),
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
                crate::warn!(
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
            outcome.count_failed(&scene, scheme, &run);
            crate::warn!(
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
            status: match (&r.failure, r.interrupted) {
                (Some(e), _) => format!("failed: {e}"),
                (None, true) => "interrupted".to_string(),
                (None, false) => "completed".to_string(),
            },
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
        crate::output::write_atomic(&rpath, &json)
            .with_context(|| format!("writing {}", rpath.display()))
            .map_err(AppError::Output)?;
        if r.interrupted {
            let stop = opts.stop.as_ref();
            return Err(AppError::Interrupted {
                message: format!(
                    "{}: {run} stopped after step {} (t = {}); its checkpoint is {}; `--resume` \
                     continues the scene",
                    stop.map_or("stopped", |s| s.signal_name()),
                    r.step,
                    r.t,
                    cpath.display()
                ),
                code: stop.map_or(exit::INTERRUPTED, |s| s.exit_code()),
            });
        }
        if opts.verbose {
            let n = (r.particles.0 + r.particles.1) as f64;
            let per_step = r.wall_s / r.segment_steps.max(1) as f64;
            crate::say!(
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
                        "wall_contacts",
                    ]
                    .iter()
                    .filter(|_| r.particles.1 > 0)
                    .filter_map(|k| r.results.get(*k).map(|v| format!("{k} {v}"))),
                )
                .collect();
            if !key.is_empty() {
                crate::say!("      {}", key.join("  "));
            }
            crate::say_part!("{}", breakdown(&r));
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
