//! Running one scene: time series to CSV, checks against the references.

use crate::flags::Preset;
use anyhow::Context;
use sph_cases::cavity;
use sph_cases::drop::{self, DropRecord};
use sph_cases::reference::References;
use sph_cases::{CaseError, CaseKind, Check, Scene, prescribed};
use sph_core::{D2, D3, Dim};
use sph_integrators::SchemeKind;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The reference set: the compiled-in copy of `cases/reference/`, with the files present in
/// `dir` (if given) read in its place.
pub fn load_references(dir: Option<&Path>) -> anyhow::Result<References> {
    let Some(dir) = dir else {
        return Ok(References::embedded().clone());
    };
    anyhow::ensure!(
        dir.is_dir(),
        "--references {}: not a directory",
        dir.display()
    );
    let mut replaced = Vec::new();
    let mut failed = None;
    let refs = References::parse(|file| {
        let path = dir.join(file);
        if !path.exists() {
            return None;
        }
        match std::fs::read_to_string(&path) {
            Ok(text) => {
                replaced.push(file.to_string());
                Some(text)
            }
            Err(e) => {
                failed.get_or_insert(format!("reading {}: {e}", path.display()));
                None
            }
        }
    })
    .with_context(|| format!("reference tables from {}", dir.display()))?;
    if let Some(message) = failed {
        anyhow::bail!(message);
    }
    println!(
        "references: {} from {} (others compiled in)",
        if replaced.is_empty() {
            "none".to_string()
        } else {
            replaced.join(", ")
        },
        dir.display()
    );
    Ok(refs)
}

/// `<stem>.checkpoint.scene.json`: the scene a checkpoint was written under.
fn scene_record_path(checkpoint: &Path) -> PathBuf {
    checkpoint.with_extension("scene.json")
}

/// Scene keys a resumed run may change: when it ends, what it records and checks, which
/// schemes the command runs and how the (same) linear systems are solved.
const RESUMABLE_KEYS: [&str; 4] = ["t_end", "schemes", "solver", "solver_tolerance"];
const RESUMABLE_CAVITY_KEYS: [&str; 4] =
    ["snapshots", "sample_every", "ghia_tolerance", "check_ghia"];

/// Refuses to resume a checkpoint under a scene whose physics differs from the one it was
/// written under (recorded beside it). A checkpoint without a record predates the record
/// (2026-11-30); every such run used `wall_condition = "reflection"`, so it is refused under
/// any other wall condition.
fn check_checkpoint_scene(record: &Path, scene: &Scene) -> anyhow::Result<()> {
    let physics = |mut v: serde_json::Value| {
        if let Some(m) = v.as_object_mut() {
            for k in RESUMABLE_KEYS {
                m.remove(k);
            }
            if let Some(c) = m.get_mut("cavity").and_then(|c| c.as_object_mut()) {
                for k in RESUMABLE_CAVITY_KEYS {
                    c.remove(k);
                }
            }
        }
        v
    };
    let current = physics(serde_json::to_value(scene)?);
    if !record.exists() {
        let condition = scene.cavity.as_ref().map(|c| c.wall_condition);
        if condition.is_some_and(|c| c != sph_integrators::WallCondition::Reflection) {
            anyhow::bail!(
                "the checkpoint has no scene record ({}): it was written before 2026-11-30, \
                 when every cavity ran with wall_condition = \"reflection\"; resuming it with \
                 {:?} would change the physics mid-run. Add wall_condition = \"reflection\" to \
                 the scene's [cavity] table to continue it, or start afresh",
                record.display(),
                condition.expect("checked")
            );
        }
        return Ok(());
    }
    let text =
        std::fs::read_to_string(record).with_context(|| format!("reading {}", record.display()))?;
    let written = physics(
        serde_json::from_str(&text).with_context(|| format!("parsing {}", record.display()))?,
    );
    if written != current {
        let (w, c) = (written.as_object(), current.as_object());
        let mut keys: Vec<String> = w
            .into_iter()
            .chain(c)
            .flat_map(|m| m.keys().cloned())
            .filter(|k| w.and_then(|m| m.get(k)) != c.and_then(|m| m.get(k)))
            .collect();
        keys.sort();
        keys.dedup();
        anyhow::bail!(
            "the checkpoint was written under another scene ({} differs: {}); resuming would \
             change the physics mid-run",
            record.display(),
            keys.join(", ")
        );
    }
    Ok(())
}

/// Reads and validates a scene file.
pub fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading scene {}", path.display()))?;
    Ok(Scene::parse(&path.display().to_string(), &text)?)
}

/// The file stem of a scene path (output-file prefix).
pub fn scene_stem(path: &Path) -> String {
    path.file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
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
    if let Some(re) = args.re {
        match scene.cavity.as_mut() {
            Some(c) => c.reynolds = re,
            None => anyhow::bail!("--re applies to lid_driven_cavity scenes only"),
        }
    }
    if let Some(k) = &args.kernel {
        scene.kernel = serde_json::from_value(serde_json::Value::String(k.clone()))
            .with_context(|| format!("--kernel {k:?}"))?;
    }
    if let Some(list) = &args.schemes {
        scene.schemes = list
            .split(',')
            .map(|s| {
                serde_json::from_value(serde_json::Value::String(s.trim().to_string()))
                    .with_context(|| format!("--schemes: unknown scheme {s:?}"))
            })
            .collect::<anyhow::Result<_>>()?;
    }
    if let Some(k) = &args.solver {
        scene.solver = serde_json::from_value(serde_json::Value::String(k.clone()))
            .with_context(|| format!("--solver {k:?}"))?;
    }
    if let Some(t) = args.solver_tolerance {
        scene.solver_tolerance = Some(t);
    }
    if let Some(a) = args.shifting {
        scene.effects.shifting = Some(sph_cases::ShiftingSpec { coefficient: a });
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

/// Output and continuation options of a run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Cavity: checkpoint every this many steps (other cases are short and ignore it).
    pub checkpoint_every: Option<usize>,
    /// Cavity: resume from the checkpoint file if it exists.
    pub resume: bool,
    /// MCAP particle-frame stride (records between frames).
    pub frame_stride: Option<usize>,
}

/// Checks and runs of one scene.
#[derive(Default)]
pub struct SceneResult {
    /// Pass/fail checks.
    pub checks: Vec<Check>,
    /// One entry per scheme run.
    pub runs: Vec<RunInfo>,
}

/// Runs `scene` (with the preset applied), writing `<out>/<name>_<scheme>.csv` and
/// `<out>/<name>-<scheme>.mcap` per scheme, and
/// returns its checks.
pub fn run_scene(
    scene: &Scene,
    name: &str,
    preset: Preset,
    refs: &References,
    out: &Path,
    options: &RunOptions,
) -> anyhow::Result<SceneResult> {
    let scene = match preset {
        Preset::Quick => scene.quick(),
        Preset::Paper => scene.clone(),
    };
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    match scene.case {
        CaseKind::EllipticalDrop => run_drop::<D2>(&scene, name, refs, out, options),
        CaseKind::SpheroidDrop => run_drop::<D3>(&scene, name, refs, out, options),
        CaseKind::PrescribedEllipse => run_prescribed::<D2>(&scene, name, refs, out),
        CaseKind::PrescribedEllipsoid => run_prescribed::<D3>(&scene, name, refs, out),
        CaseKind::LidDrivenCavity if scene.dim == 2 => {
            run_cavity::<D2>(&scene, name, refs, out, options)
        }
        CaseKind::LidDrivenCavity => run_cavity::<D3>(&scene, name, refs, out, options),
    }
}

const CAVITY_HEADER: &str = "scheme,step,t,kinetic_energy,density_error_rms,density_change_rms,density_error_max,mean_pressure,pressure_range,wall_penetrations,solver_iterations,max_div_u,gauge_multiplier,det_f_min,det_f_mean,det_f_max,step_seconds,ghia_u_rms,ghia_u_max,ghia_v_rms,ghia_v_max,wall_intrusion";

fn cavity_row(r: &cavity::CavityRecord) -> String {
    let det = r.det_f.unwrap_or_default();
    let ghia = r.ghia.map_or(",,,".to_string(), |g| {
        format!(
            "{:.5e},{:.5e},{:.5e},{:.5e}",
            g.u_rms, g.u_max, g.v_rms, g.v_max
        )
    });
    format!(
        "{},{},{:.9e},{:.9e},{:.6e},{:.6e},{:.6e},{:.3e},{:.6e},{},{},{:.3e},{:.3e},{:.9e},{:.9e},{:.9e},{:.4e},{ghia},{:.4e}",
        r.scheme.name(),
        r.step,
        r.t,
        r.kinetic_energy,
        r.density_error_rms,
        r.density_change_rms,
        r.density_error_max,
        r.mean_pressure,
        r.pressure_range,
        r.wall_penetrations,
        r.solver_iterations,
        r.max_div_u,
        r.gauge_multiplier,
        det.min,
        det.mean,
        det.max,
        r.step_seconds,
        r.wall_intrusion,
    )
}

fn write_file(path: &Path, text: &str) -> anyhow::Result<()> {
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

/// Resolution of the progress bars (fraction of the end time).
const PROGRESS_TICKS: u64 = 1000;

/// The files of one scheme's run: the CSV time series (one row per record, flushed as it is
/// produced, so a failing step loses nothing already computed) and the MCAP log (finished on
/// every path: explicitly by [`SchemeOutput::finish`], or on drop).
struct SchemeOutput {
    header: &'static str,
    csv_path: PathBuf,
    csv: std::io::BufWriter<std::fs::File>,
    sink: crate::mcap_sink::McapSink,
    progress: indicatif::ProgressBar,
    t_end: f64,
}

impl SchemeOutput {
    /// Creates `<out>/<stem>.csv` (with `header`) and `<out>/<mcap_stem>.mcap` (every
    /// `stride`-th particle frame, the scene as metadata).
    /// With `resume_step`, an existing CSV is continued (a run resumed from the checkpoint of
    /// that step) instead of replaced; its rows after that step, written between the checkpoint
    /// and the interruption, are dropped first so the continued series has no duplicates.
    #[allow(clippy::too_many_arguments)]
    fn create<D: Dim>(
        out: &Path,
        csv_path: PathBuf,
        mcap_stem: &str,
        header: &'static str,
        scene: &Scene,
        scheme: SchemeKind,
        stride: usize,
        resume_step: Option<usize>,
    ) -> anyhow::Result<Self> {
        let continuing = resume_step.is_some() && csv_path.exists();
        if let (true, Some(step)) = (continuing, resume_step) {
            truncate_csv_after_step(&csv_path, header, step)?;
        }
        let file = std::fs::OpenOptions::new()
            .create(true)
            .write(true)
            .append(continuing)
            .truncate(!continuing)
            .open(&csv_path)
            .with_context(|| format!("creating {}", csv_path.display()))?;
        let mut csv = std::io::BufWriter::new(file);
        if !continuing {
            writeln!(csv, "{header}")?;
        }
        let mut meta = std::collections::BTreeMap::new();
        meta.insert("case".into(), scene.case.name().to_string());
        meta.insert("scheme".into(), scheme.name().to_string());
        meta.insert("dim".into(), D::DIM.to_string());
        meta.insert("scene".into(), serde_json::to_string(scene)?);
        let mcap_path = out.join(format!("{mcap_stem}.mcap"));
        let sink = crate::mcap_sink::McapSink::create(&mcap_path, stride, meta)?;
        // Drawn on stderr only when it is a terminal (indicatif hides it otherwise, so CI logs
        // and redirected output stay clean).
        let progress = indicatif::ProgressBar::new(PROGRESS_TICKS);
        progress.set_style(
            indicatif::ProgressStyle::with_template(
                "  {prefix:<28} [{bar:30}] {msg:<14} {elapsed_precise} (eta {eta})",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        progress.set_prefix(format!("{} {}", scene.case.name(), scheme.name()));
        Ok(Self {
            header,
            csv_path,
            csv,
            sink,
            progress,
            t_end: scene.t_end,
        })
    }

    /// Writes one CSV row and logs it (as a flat JSON object keyed by the header) with the frame.
    fn record(&mut self, row: &str, frame: &dyn sph_integrators::Frame) -> std::io::Result<()> {
        let metrics: serde_json::Map<String, serde_json::Value> = self
            .header
            .split(',')
            .zip(row.split(','))
            .map(|(k, v)| {
                (
                    k.to_string(),
                    v.parse::<f64>().map_or_else(|_| v.into(), |x| x.into()),
                )
            })
            .collect();
        self.sink.frame(frame, &serde_json::Value::Object(metrics));
        let t = frame.time();
        self.progress
            .set_position((t / self.t_end * PROGRESS_TICKS as f64).round() as u64);
        self.progress.set_message(format!("t = {t:.4}"));
        writeln!(self.csv, "{row}")?;
        self.csv.flush()
    }

    fn finish(&mut self) -> anyhow::Result<()> {
        self.progress.finish_and_clear();
        self.sink.finish()
    }

    /// Reports a failed run on stderr (as `who`) and as the failing check `<what> run completes`.
    fn failed(&self, case: &str, who: &str, what: &str, error: &CaseError) -> Check {
        eprintln!(
            "  {who}: FAILED: {error} (rows so far in {})",
            self.csv_path.display()
        );
        Check::new(
            case,
            format!("{what} run completes"),
            0.0,
            1.0,
            0.0,
            error.to_string(),
        )
    }
}

/// Rewrites the CSV at `path` without its data rows whose `step` column (the second) exceeds
/// `step` (atomically: a temporary file renamed over it). Rows that do not parse are kept. A CSV
/// whose header is not `header` (written by another version, with other columns) is an error
/// and is left as it is: appending rows of a different layout would corrupt it.
fn truncate_csv_after_step(path: &Path, header: &str, step: usize) -> anyhow::Result<()> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let found = text.lines().next().unwrap_or("");
    if found != header {
        anyhow::bail!(
            "cannot resume into {}: its header has other columns than this version writes \
             (found {:?}, expected {:?}); move the CSV away or resume with --out in a fresh \
             directory holding a copy of the checkpoint",
            path.display(),
            found,
            header
        );
    }
    let mut kept = String::with_capacity(text.len());
    for (i, line) in text.lines().enumerate() {
        let later = i > 0
            && line
                .split(',')
                .nth(1)
                .and_then(|s| s.parse::<usize>().ok())
                .is_some_and(|s| s > step);
        if !later {
            kept.push_str(line);
            kept.push('\n');
        }
    }
    if kept.len() != text.len() {
        let tmp = path.with_extension("csv.tmp");
        std::fs::write(&tmp, &kept).with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, path).with_context(|| format!("replacing {}", path.display()))?;
    }
    Ok(())
}

fn run_cavity<D: Dim>(
    scene: &Scene,
    name: &str,
    refs: &References,
    out: &Path,
    options: &RunOptions,
) -> anyhow::Result<SceneResult> {
    let case = scene.case.name();
    let mut result = SceneResult::default();
    for &scheme in &scene.schemes {
        let stem = format!("{name}_{}", scheme.name());
        let checkpoint_path = out.join(format!("{stem}.checkpoint.json"));
        let resume: Option<sph_integrators::Checkpoint> =
            if options.resume && checkpoint_path.exists() {
                let text = std::fs::read_to_string(&checkpoint_path)
                    .with_context(|| format!("reading {}", checkpoint_path.display()))?;
                let c: sph_integrators::Checkpoint = serde_json::from_str(&text)
                    .with_context(|| format!("parsing {}", checkpoint_path.display()))?;
                check_checkpoint_scene(&scene_record_path(&checkpoint_path), scene)?;
                println!(
                    "  {stem}: resuming from step {} (t = {}) in {}",
                    c.step,
                    c.t,
                    checkpoint_path.display()
                );
                Some(c)
            } else {
                None
            };
        let mcap_stem = match &resume {
            Some(c) => format!("{name}-{}-from-step{}", scheme.name(), c.step),
            None => format!("{name}-{}", scheme.name()),
        };
        // About 40 particle frames per run by default; metrics at every record.
        let mut output = SchemeOutput::create::<D>(
            out,
            out.join(format!("{stem}.csv")),
            &mcap_stem,
            CAVITY_HEADER,
            scene,
            scheme,
            options.frame_stride.unwrap_or(10),
            resume.as_ref().map(|c| c.step),
        )?;
        // Checkpoints are written to a temporary file and renamed, so a run killed mid-write
        // keeps the previous checkpoint.
        // The scene beside it, so a resume under different physics is refused.
        let scene_record = serde_json::to_vec_pretty(scene)?;
        let mut save = |c: &sph_integrators::Checkpoint| -> std::io::Result<()> {
            let tmp = checkpoint_path.with_extension("json.tmp");
            std::fs::write(&tmp, serde_json::to_vec(c)?)?;
            std::fs::rename(&tmp, &checkpoint_path)?;
            std::fs::write(scene_record_path(&checkpoint_path), &scene_record)
        };
        let control = cavity::RunControl {
            resume: resume.as_ref(),
            checkpoint_every: options.checkpoint_every,
            save: Some(&mut save),
        };
        let t0 = std::time::Instant::now();
        let outcome = cavity::run_with::<D>(scene, scheme, refs, control, &mut |r, frame| {
            output.record(&cavity_row(r), frame)
        });
        output.finish()?;
        let wall_s = t0.elapsed().as_secs_f64();
        let run = match outcome {
            Ok(r) => r,
            Err(e) => {
                let label = format!("{name} {}", scheme.name());
                result.checks.push(output.failed(case, &label, &label, &e));
                continue;
            }
        };
        let mut prof = String::from("profile,coord,value,ghia\n");
        for (c, v, g) in &run.profiles.u_vertical {
            prof += &format!("u_vertical,{c},{v:.6e},{g}\n");
        }
        for (c, v, g) in &run.profiles.v_horizontal {
            prof += &format!("v_horizontal,{c},{v:.6e},{g}\n");
        }
        write_file(&out.join(format!("{stem}_profiles.csv")), &prof)?;
        for snap in &run.snapshots {
            let mut text = String::from("x,y,z,density_error\n");
            for (x, e) in snap.probes.iter().zip(&snap.error) {
                text += &format!("{},{},{},{e:.6e}\n", x[0], x[1], x[2]);
            }
            write_file(
                &out.join(format!("{stem}_density_t{:.3}.csv", snap.t)),
                &text,
            )?;
        }
        let last = run.records.last().expect("initial record");
        let steps = last.step;
        let stepped: Vec<_> = run.records.iter().filter(|r| r.step > 0).collect();
        let iters = stepped
            .iter()
            .map(|r| r.solver_iterations as f64)
            .sum::<f64>()
            / stepped.len().max(1) as f64;
        // Steps taken by this process (a resumed run started at the checkpoint's step).
        let taken = steps - resume.as_ref().map_or(0, |c| c.step);
        let per_step = wall_s / taken.max(1) as f64;
        let n = run.particles.0 + run.particles.1;
        let ghia = run.ghia.map_or("—".to_string(), |g| {
            format!(
                "Ghia u rms {:.4} max {:.4} v rms {:.4} max {:.4}",
                g.u_rms, g.u_max, g.v_rms, g.v_max
            )
        });
        println!(
            "  {name} {:<19} fluid={} walls={} ({}) steps={steps} t={:.3} KE {:.4e} ρ̂ rms {:.3e} (Δ {:.3e}) max pen {} (depth {:.3} dx) steady {}  {ghia}  iters/step {iters:.1}  {:.4} s/step  {:.3e} particle-steps/s  [{wall_s:.1} s]",
            scheme.name(),
            run.particles.0,
            run.particles.1,
            scene
                .cavity
                .as_ref()
                .map_or("—".into(), |c| format!("{:?}", c.wall_condition)
                    .to_lowercase()),
            last.t,
            last.kinetic_energy,
            last.density_error_rms,
            last.density_change_rms,
            run.max_penetrations(),
            run.max_intrusion() / scene.dx,
            run.steady_time.map_or("no".into(), |t| format!("t={t:.2}")),
            per_step,
            n as f64 / per_step,
        );
        result.checks.extend(cavity::checks(
            &format!("{case}/{name}"),
            scene,
            scheme,
            &run,
        ));
        result.runs.push(RunInfo {
            case: name.to_string(),
            scheme: scheme.name().to_string(),
            kernel: format!("{:?}", scene.kernel),
            dim: D::DIM,
            particles: n,
            steps: taken,
            wall_s,
            solver_iters_mean: iters,
        });
    }
    Ok(result)
}

/// `<out>/<name>_<scheme>.csv`: `name` is the run's file prefix (the scene file's stem, or
/// `run --tag`), so runs of one case under different names do not overwrite each other.
fn csv_path(out: &Path, name: &str, scheme: &str) -> PathBuf {
    out.join(format!("{name}_{scheme}.csv"))
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

fn run_drop<D: Dim>(
    scene: &Scene,
    name: &str,
    refs: &References,
    out: &Path,
    options: &RunOptions,
) -> anyhow::Result<SceneResult> {
    let case = scene.case.name();
    let mut checks = Vec::new();
    let mut runs = Vec::new();
    let mut infos = Vec::new();
    let n_particles = drop::setup::<D>(scene, refs).particles.len();
    for &scheme in &scene.schemes {
        let mut output = SchemeOutput::create::<D>(
            out,
            csv_path(out, name, scheme.name()),
            &format!("{name}-{}", scheme.name()),
            DROP_HEADER,
            scene,
            scheme,
            options.frame_stride.unwrap_or(1),
            None,
        )?;
        let mut first: Option<DropRecord> = None;
        let t0 = std::time::Instant::now();
        let records = drop::run::<D>(scene, scheme, refs, &mut |r, frame| {
            let f = first.get_or_insert_with(|| r.clone());
            output.record(&drop_row(r, f), frame)
        });
        output.finish()?;
        let records = match records {
            Ok(r) => r,
            Err(e) => {
                let who = format!("{case} {}", scheme.name());
                checks.push(output.failed(case, &who, scheme.name(), &e));
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

fn run_prescribed<D: Dim>(
    scene: &Scene,
    name: &str,
    refs: &References,
    out: &Path,
) -> anyhow::Result<SceneResult> {
    let t0 = std::time::Instant::now();
    let (runs, checks) = prescribed::run_scene::<D>(scene, refs);
    let wall_s = t0.elapsed().as_secs_f64();
    let mut infos = Vec::new();
    for run in &runs {
        let path = csv_path(out, name, run.update.name());
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A run interrupted after its last checkpoint has CSV rows past it; resuming drops them
    /// (they are recomputed) so the continued series has each step once.
    #[test]
    fn resumed_csv_drops_rows_after_the_checkpoint() {
        let dir = std::env::temp_dir().join(format!("dgsph-resume-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("c_dg.csv");
        std::fs::write(
            &path,
            "scheme,step,t\ndg,0,0\ndg,800,1\ndg,900,1.1\ndg,1100,1.4\n",
        )
        .unwrap();
        truncate_csv_after_step(&path, "scheme,step,t", 800).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, "scheme,step,t\ndg,0,0\ndg,800,1\n");
        // A CSV of another layout is refused and left untouched.
        let err = truncate_csv_after_step(&path, "scheme,step,t,extra", 0).unwrap_err();
        assert!(err.to_string().contains("other columns"), "{err}");
        let after = std::fs::read_to_string(&path).unwrap();
        assert_eq!(after, text);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Two runs of one drop case under different names (`run --tag`) write separate CSV and
    /// MCAP files into the same directory instead of overwriting each other.
    #[test]
    fn run_name_prefixes_drop_outputs() {
        let dir = std::env::temp_dir().join(format!("dgsph-run-name-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let scene = Scene {
            schemes: vec![SchemeKind::Euler],
            ..Scene::paper_drop(CaseKind::EllipticalDrop, 0.1, 2e-4, 4e-4)
        };
        let refs = References::embedded();
        for name in ["first", "second"] {
            run_scene(
                &scene,
                name,
                Preset::Paper,
                refs,
                &dir,
                &RunOptions::default(),
            )
            .unwrap();
        }
        for name in ["first", "second"] {
            let csv = std::fs::read_to_string(dir.join(format!("{name}_euler.csv"))).unwrap();
            assert_eq!(csv.lines().next(), Some(DROP_HEADER), "{name}");
            assert_eq!(
                csv.lines().count(),
                1 + 3,
                "{name}: header and t = 0, 1, 2 steps"
            );
            assert!(dir.join(format!("{name}-euler.mcap")).exists(), "{name}");
        }
        assert!(!dir.join("elliptical_drop_euler.csv").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A checkpoint resumes only under the physics it was written under: the scene recorded
    /// beside it must match except for the keys a resumed run may change; one without a record
    /// (written before 2026-11-30) only under `wall_condition = "reflection"`.
    #[test]
    fn resume_is_refused_under_other_physics() {
        let dir = std::env::temp_dir().join(format!("dgsph-resume-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let record = dir.join("c_dg.checkpoint.scene.json");
        let text = "case = \"lid_driven_cavity\"\ndim = 2\ndx = 0.05\nkernel = \"wendland_c2\"\ndt = 0.01\nt_end = 1.0\nschemes = [\"dg\"]\n[cavity]\nreynolds = 100\n";
        let scene = Scene::parse("c", text).unwrap();
        // No record: refused under the default (continuation), accepted under reflection.
        let err = check_checkpoint_scene(&record, &scene)
            .unwrap_err()
            .to_string();
        assert!(err.contains("reflection"), "{err}");
        let mut reflection = scene.clone();
        reflection.cavity.as_mut().unwrap().wall_condition =
            sph_integrators::WallCondition::Reflection;
        check_checkpoint_scene(&record, &reflection).unwrap();
        // With a record: a longer run, other schemes or snapshots, another solver are fine.
        std::fs::write(&record, serde_json::to_vec(&scene).unwrap()).unwrap();
        let mut longer = scene.clone();
        longer.t_end = 40.0;
        longer.schemes = vec![SchemeKind::Euler];
        longer.cavity.as_mut().unwrap().snapshots = vec![5.0];
        longer.solver_tolerance = Some(1e-6);
        check_checkpoint_scene(&record, &longer).unwrap();
        // Other physics is refused, naming what differs.
        let mut finer = scene.clone();
        finer.dx = 0.025;
        let err = check_checkpoint_scene(&record, &finer)
            .unwrap_err()
            .to_string();
        assert!(err.contains("differs: dx"), "{err}");
        let err = check_checkpoint_scene(&record, &reflection)
            .unwrap_err()
            .to_string();
        assert!(err.contains("differs: cavity"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
