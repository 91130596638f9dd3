//! The one run loop of every case: stepping, sampling, the common record columns, checkpoints,
//! resume, blow-up handling, and the checks of the scene's `[[check]]` tables.
//!
//! [`run_scheme`] runs one scheme of a scene with a [`Case`]; everything it produces reaches the
//! caller through a [`RunSink`] as soon as it exists (records with the particle state, tables,
//! checkpoints), so a run that fails or is killed loses nothing already handed out. The library
//! does no I/O: the sink writes files.

use crate::case::{Case, Column, Results, Table};
use crate::{CaseError, Check, Scene};
use sph_core::{Dim, VectorOps};
use sph_integrators::{
    COLLAPSE_FRACTION, Checkpoint, DtBound, Frame, Phase, PhaseTimes, Scheme, SchemeKind,
    Simulation, StepError, StepReport,
};
use sph_kernels::Kernel;
use std::time::Instant;

/// Receives what a run produces, as it is produced.
pub trait RunSink {
    /// The record columns, once before the first record.
    fn begin(&mut self, columns: &[Column]) -> std::io::Result<()>;
    /// One record (one value per column, NaN where there is none) with the particle state;
    /// `frame_due` says whether the scene's frame cadence asks for the particle frame.
    fn record(&mut self, values: &[f64], frame: &dyn Frame, frame_due: bool)
    -> std::io::Result<()>;
    /// A table (snapshot field, profiles).
    fn table(&mut self, table: &Table) -> std::io::Result<()>;
    /// A checkpoint to write (every `checkpoint_every` steps and after the last step).
    fn checkpoint(&mut self, checkpoint: &Checkpoint) -> std::io::Result<()>;
    /// Called after every step (progress display). Default: nothing.
    fn progress(&mut self, _step: usize, _t: f64, _t_end: f64) {}
}

/// How a run starts and saves its state.
#[derive(Default)]
pub struct RunControl<'a> {
    /// Continue from this checkpoint (of the same scene and scheme) instead of t = 0. The
    /// initial record is not observed again.
    pub resume: Option<&'a Checkpoint>,
    /// Hand a checkpoint to the sink every this many steps (and after the last step). The
    /// linear solver starts afresh after each (an AMG hierarchy kept between solves is not in
    /// the checkpoint), so a run resumed from one solves as the run that wrote it goes on.
    pub checkpoint_every: Option<usize>,
    /// Metadata stored in the checkpoints (the caller's record of the scene).
    pub checkpoint_meta: String,
    /// Set (by a signal handler, say) to stop the run after the step in progress (or, while the
    /// linear solver keeps set-up work it would use, after the first step where it keeps none:
    /// at most 10 solves later): a checkpoint is handed out and the run ends with
    /// [`SchemeRun::interrupted`].
    pub stop: Option<&'a std::sync::atomic::AtomicBool>,
}

/// What one scheme's run produced (besides what went to the sink).
#[derive(Debug)]
pub struct SchemeRun {
    /// The scheme.
    pub scheme: SchemeKind,
    /// Fluid and wall particles.
    pub particles: (usize, usize),
    /// Fluid lattice sites left out because they lie in wall material.
    pub carved: usize,
    /// Steps taken over the whole run (a resumed run's earlier segments included; settling
    /// steps not).
    pub steps_taken: usize,
    /// Steps taken by this process (what [`SchemeRun::phases`] timed).
    pub segment_steps: usize,
    /// The step count at the end.
    pub step: usize,
    /// Time at the end.
    pub t: f64,
    /// Wall time of this process's part of the run in seconds.
    pub wall_s: f64,
    /// Time per pass, summed over the steps taken.
    pub phases: PhaseTimes,
    /// Named results (the loop's and the case's).
    pub results: Results,
    /// Checks: the case's built-in ones and the scene's `[[check]]`s (and "run completes").
    pub checks: Vec<Check>,
    /// The step that failed, if one did (the run stopped there; all before it was handed out).
    pub failure: Option<StepError>,
    /// The run stopped early at [`RunControl::stop`], after handing out a checkpoint.
    pub interrupted: bool,
}

/// The columns every record starts with, before the case's own.
pub fn common_columns() -> Vec<Column> {
    let mut c = vec![
        Column::new("step", "", "steps completed"),
        Column::new("t", "time", "simulated time"),
        Column::new("dt", "time", "size of the last step"),
        Column::new(
            "dt_bound",
            "",
            "the limit that set the last step with the automatic step: 0 the scene's dt, 1 \
             advective, 2 viscous, 3 body force (empty with a fixed step)",
        ),
        Column::new("kinetic_energy", "energy", "½ Σ m u² over the fluid"),
        Column::new("max_speed", "velocity", "largest fluid speed"),
        Column::new("wall_penetrations", "", "fluid particles in wall material"),
        Column::new(
            "wall_intrusion",
            "length",
            "depth of the deepest fluid particle in wall material",
        ),
        Column::new(
            "left_domain",
            "",
            "fluid particles that left the domain over an open wall's rim (held there, at rest)",
        ),
        Column::new(
            "free_surface_particles",
            "",
            "Dirichlet (free-surface) particles of the last projection",
        ),
        Column::new(
            "solver_iterations",
            "",
            "pressure-solver iterations of the last step",
        ),
        Column::new(
            "solver_residual",
            "",
            "true relative residual of the last solve",
        ),
        Column::new(
            "max_div_u",
            "1/time",
            "max |∇·u| after the last projection (diagnostic div_u)",
        ),
        Column::new(
            "det_f_min",
            "",
            "min det F of the last step (diagnostic det_f)",
        ),
        Column::new(
            "det_f_mean",
            "",
            "mean det F of the last step (diagnostic det_f)",
        ),
        Column::new(
            "det_f_max",
            "",
            "max det F of the last step (diagnostic det_f)",
        ),
        Column::new(
            "max_displacement",
            "h",
            "largest fluid displacement of the last step, in smoothing lengths",
        ),
        Column::new(
            "wall_guarded",
            "",
            "fluid particles the walls' guard stopped from crossing a wall in the last step",
        ),
        Column::new(
            "wall_contacts",
            "",
            "free-surface particles in contact with a wall whose velocity into it the free-surface \
             wall condition removed in the last step",
        ),
        Column::new(
            "energy_explicit",
            "energy",
            "change of the fluid's kinetic energy by the explicit forces (gravity, viscosity) in \
             the last step",
        ),
        Column::new(
            "energy_projection",
            "energy",
            "change of the fluid's kinetic energy by the pressure projection in the last step",
        ),
        Column::new(
            "energy_regularisation",
            "energy",
            "change of the fluid's kinetic energy by shifting's velocity correction and the \
             walls' guard in the last step",
        ),
        Column::new("step_seconds", "s", "wall time of the last step"),
        Column::new(
            "density_error",
            "",
            "max |ρ̂/ρ̂_lattice − 1| over interior fluid particles (summation density; interior: \
             no free-surface particle in the kernel support)",
        ),
    ];
    for p in Phase::ALL {
        c.push(Column::new(
            format!("seconds_{}", p.name()),
            "s",
            "wall time of this pass in the last step (empty: the pass did not run)",
        ));
    }
    c
}

/// The names of the results every run reports (cases add their own).
pub const COMMON_RESULTS: [&str; 14] = [
    "reached_t",
    "steps",
    "max_wall_penetrations",
    "max_wall_intrusion_dx",
    "max_speed",
    "max_displacement",
    "wall_guarded",
    "wall_contacts",
    "kinetic_energy",
    "solver_iterations_mean",
    "wall_seconds",
    "completed",
    "density_error_max",
    "max_speed_ratio",
];

/// Summation density `ρ̂ = m Σ_k W(|k| dx)` of a particle inside a perfect lattice of spacing
/// `dx` and particle mass `m`: the reference of [`interior_density_error`], so the lattice's
/// own kernel-sum offset (a fraction of a per cent) is not counted as compression. The lattice
/// sum is [`sph_operators::lattice_kernel_sum`], the one density relaxation measures against.
pub fn lattice_density<D: Dim>(sim: &Simulation<D>, dx: f64, mass: f64) -> f64 {
    let volume = dx.powi(D::DIM as i32);
    mass / volume * sph_operators::lattice_kernel_sum(sim.kernel(), volume)
}

/// Largest `|ρ̂_i/ρ̂_lattice − 1|` over interior fluid particles, `ρ̂_i = Σ_j m_j W(|x_i − x_j|)`
/// over the last projection's neighbour lists at the current positions (a pair entering the
/// support during the step is missed, but W vanishes smoothly there). Interior: neither the
/// particle nor any neighbour was a free-surface particle. NaN before the first step.
pub fn interior_density_error<D: Dim>(sim: &Simulation<D>, lattice: f64) -> f64 {
    use rayon::prelude::*;
    let list = sim.neighbors();
    let nf = sim.fluid_len();
    if list.len() < nf || nf == 0 {
        return f64::NAN;
    }
    let flags = sim.free_surface_flags();
    let surface = |j: usize| flags.get(j).copied().unwrap_or(false);
    let p = &sim.particles;
    let kernel = sim.kernel();
    let periodic = sim.periodic();
    let worst = (0..nf)
        .into_par_iter()
        .filter_map(|i| {
            let row = list.row(i);
            if surface(i) || row.iter().any(|&j| surface(j as usize)) {
                return None;
            }
            let xi = p.positions[i];
            let rho: f64 = row
                .iter()
                .map(|&j| {
                    let mut d = xi - p.positions[j as usize];
                    if let Some(per) = periodic {
                        d = per.minimum_image(d);
                    }
                    p.masses[j as usize] * kernel.w(d.length())
                })
                .sum();
            Some((rho / lattice - 1.0).abs())
        })
        .reduce(|| f64::NEG_INFINITY, f64::max);
    if worst.is_finite() { worst } else { f64::NAN }
}

/// The velocity scale of `max_speed_ratio` when the case gives none: the initial largest fluid
/// speed; for fluid at rest under gravity `√(|g| H)`, `H` the fluid's height along `g`.
fn default_velocity_scale<D: Dim>(scene: &Scene, sim: &Simulation<D>) -> f64 {
    let nf = sim.fluid_len();
    let u = sim.max_speed();
    if u > 0.0 {
        return u;
    }
    let Some(g) = scene.effects.gravity else {
        return f64::NAN;
    };
    let g = D::Vector::from_fn(|k| g[k]);
    let gn = g.length();
    if gn.is_nan() || gn <= 0.0 {
        return f64::NAN;
    }
    let dir = g * (1.0 / gn);
    let (lo, hi) = sim.particles.positions[..nf]
        .iter()
        .map(|x| x.dot(dir))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    (gn * (hi - lo + scene.dx)).sqrt()
}

fn common_values<D: Dim>(
    sim: &Simulation<D>,
    report: Option<&StepReport>,
    dt_bound: Option<DtBound>,
    lattice: f64,
    out: &mut Vec<f64>,
) {
    let p = &sim.particles;
    let nf = sim.fluid_len();
    let ke = 0.5
        * p.masses[..nf]
            .iter()
            .zip(&p.velocities[..nf])
            .map(|(m, u)| m * u.length_squared())
            .sum::<f64>();
    let vmax = p.velocities[..nf]
        .iter()
        .map(|u| u.length())
        .fold(0.0, f64::max);
    let nan = f64::NAN;
    let r = |f: &dyn Fn(&StepReport) -> f64| report.map_or(nan, f);
    let det = report.and_then(|r| r.det_f);
    out.extend_from_slice(&[
        sim.step as f64,
        sim.t,
        r(&|r| r.dt),
        report.and(dt_bound).map_or(nan, DtBound::code),
        ke,
        vmax,
        sim.wall_penetrations() as f64,
        sim.wall_intrusion(),
        sim.left_domain() as f64,
        r(&|r| r.free_surface_particles as f64),
        r(&|r| r.solve.iterations as f64),
        r(&|r| r.solve.rel_residual),
        report.and_then(|r| r.max_div_u).unwrap_or(nan),
        det.map_or(nan, |d| d.min),
        det.map_or(nan, |d| d.mean),
        det.map_or(nan, |d| d.max),
        r(&|r| r.max_displacement),
        r(&|r| r.wall_guarded as f64),
        r(&|r| r.wall_contacts as f64),
        r(&|r| r.energy.explicit),
        r(&|r| r.energy.projection),
        r(&|r| r.energy.regularisation),
        r(&|r| r.seconds),
        interior_density_error(sim, lattice),
    ]);
    for ph in Phase::ALL {
        out.push(report.map_or(nan, |r| {
            if r.phases.ran(ph) {
                r.phases.seconds(ph)
            } else {
                nan
            }
        }));
    }
}

/// Running maxima and sums over a run's steps, for the results. A checkpoint carries it
/// ([`RunState`]), so a resumed run's results cover the whole run.
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct Tally {
    penetrations: usize,
    intrusion: f64,
    speed: f64,
    displacement: f64,
    guarded: usize,
    /// Particle-steps the free-surface wall condition changed (absent in older checkpoints).
    #[serde(default)]
    contacts: usize,
    iterations: f64,
    steps: usize,
    /// The sampled extremes of the loop's records: the density error's largest value, and the
    /// number of records (the frame cadence counts them).
    density_max: f64,
    records: usize,
    /// The smallest and largest step taken (0 before the first).
    #[serde(default)]
    dt_min: f64,
    #[serde(default)]
    dt_max: f64,
    #[serde(skip)]
    phases: PhaseTimes,
}

/// What a checkpoint carries besides the particles: the loop's [`Tally`] and the case's
/// accumulated measurements ([`Case::save_state`]). No wall-clock time, so that the same run
/// writes the same checkpoints.
fn run_state(tally: &Tally, case_state: Vec<u8>) -> Vec<u8> {
    let mut w = crate::case::StateWriter::default();
    w.put("tally", tally);
    w.put("case", &case_state);
    w.finish()
}

/// The scene's `[start] relax_iterations` (packing, [`Simulation::relax`]), then its
/// `[start] settle_steps`: that many steps of the scheme at the scene's `dt`, each
/// followed by removing the fraction `settle_damping` (default 1) of the fluid's velocity, then
/// the fluid set at rest and the clock reset to `t = 0`, step 0. The particles keep their
/// settled positions and pressures. A failed settling step is an
/// error of the run's setup (`CaseError::Settle`).
fn settle<D: Dim>(
    scene: &Scene,
    case: &mut Box<dyn Case<D>>,
    sim: &mut Simulation<D>,
    integrator: &mut Scheme,
) -> Result<(), CaseError> {
    let relax = scene.start.relax_iterations.unwrap_or(0);
    if relax > 0 {
        sim.relax(relax, scene.dx)
            .map_err(|e| CaseError::Settle(e.to_string()))?;
    }
    let steps = scene.start.settle_steps.unwrap_or(0);
    if steps == 0 {
        return Ok(());
    }
    let nf = sim.fluid_len();
    let keep = 1.0 - scene.start.settle_damping.unwrap_or(1.0);
    for _ in 0..steps {
        case.advance(sim, integrator, scene.dt)
            .map_err(|e| CaseError::Settle(e.to_string()))?;
        for u in &mut sim.particles.velocities[..nf] {
            *u *= keep;
        }
    }
    sim.particles.velocities[..nf].fill(D::Vector::ZERO);
    sim.t = 0.0;
    sim.step = 0;
    Ok(())
}

/// Runs `scheme` of `scene` with `case` to `scene.t_end`, handing records, tables and
/// checkpoints to `sink` as they are produced. A failed step ends the run with
/// [`SchemeRun::failure`] set (the particles stay as before that step; everything up to it was
/// handed out); setup errors, an unusable checkpoint and sink errors are `Err`.
pub fn run_scheme<D: Dim>(
    scene: &Scene,
    scheme: SchemeKind,
    mut case: Box<dyn Case<D>>,
    control: RunControl<'_>,
    sink: &mut dyn RunSink,
) -> Result<SchemeRun, CaseError> {
    let clock = Instant::now();
    let setup = case.setup()?;
    let carved = setup.carved;
    let mut sim = setup.simulation()?;
    let counts = (sim.fluid_len(), sim.particles.len() - sim.fluid_len());
    let (full, rest) = scene.steps();
    let last = full + usize::from(rest.is_some());
    let every = scene
        .output
        .sample_every
        .or(scene.cavity.as_ref().and_then(|c| c.sample_every))
        .unwrap_or_else(|| case.sample_every(last));
    let frame_every = scene
        .output
        .frame_every
        .unwrap_or_else(|| case.frame_every());
    let mut snapshots: Vec<f64> = scene
        .output
        .snapshots
        .iter()
        .chain(scene.cavity.iter().flat_map(|c| c.snapshots.iter()))
        .copied()
        .collect();
    snapshots.sort_by(f64::total_cmp);
    snapshots.dedup();
    let mut pending = snapshots.into_iter().peekable();
    let due = |t: f64| t + 1e-9 * scene.dt;
    let mut columns = common_columns();
    columns.extend(case.columns());
    sink.begin(&columns)?;
    let mut values = Vec::with_capacity(columns.len());
    let records = std::cell::Cell::new(0usize);
    // The limit that set the step being recorded (automatic steps).
    let bound_now = std::cell::Cell::new(None);
    let mass = sim.particles.masses.first().copied().unwrap_or(0.0);
    let lattice = lattice_density(&sim, scene.dx, mass);
    let velocity_scale = case
        .velocity_scale()
        .unwrap_or_else(|| default_velocity_scale(scene, &sim));
    let density_col = columns
        .iter()
        .position(|c| c.name == "density_error")
        .expect("a common column");
    let density_max = std::cell::Cell::new(f64::NAN);
    let mut emit = |case: &mut Box<dyn Case<D>>,
                    sim: &Simulation<D>,
                    report: Option<&StepReport>,
                    short: bool,
                    sink: &mut dyn RunSink|
     -> Result<(), CaseError> {
        values.clear();
        common_values(sim, report, bound_now.get(), lattice, &mut values);
        density_max.set(density_max.get().max(values[density_col]));
        case.observe(sim, report, short, &mut values)?;
        debug_assert_eq!(values.len(), columns.len());
        sink.record(&values, sim, records.get().is_multiple_of(frame_every))?;
        records.set(records.get() + 1);
        Ok(())
    };
    let mut integrator = Scheme::new(scheme);
    // The automatic time step reads the largest fluid speed, ν and |g| each step.
    let auto = scene.auto_time_step();
    let gravity = sim.config().effects.gravity.map_or(0.0, |g| {
        let g = &g[..D::DIM];
        g.iter().map(|c| c * c).sum::<f64>().sqrt()
    });
    // ν, and the hyperviscous term's limit as the viscosity whose limit it is.
    let nu = auto.map_or(0.0, |a| scene.limit_viscosity(&a));
    let h = sim.config().h;
    if control.resume.is_none() {
        settle(scene, &mut case, &mut sim, &mut integrator)?;
    }
    case.start(&sim)?;
    let mut tally = Tally::default();
    if let Some(c) = control.resume {
        sim.restore(c)
            .map_err(|e| CaseError::Resume(e.to_string()))?;
        if !c.state.is_empty() {
            let r = crate::case::StateReader::new(&c.state)?;
            tally = r.get("tally")?;
            case.restore_state(&r.get::<Vec<u8>>("case")?)?;
            records.set(tally.records);
            density_max.set(tally.density_max);
        }
        let expected = sim.step as f64 * scene.dt;
        let fits = match auto {
            // Automatic steps: any step count, but not past the end.
            Some(_) => sim.t <= scene.t_end + 1e-9 * scene.dt,
            None => sim.step <= last && (sim.t - expected).abs() <= 1e-9 * expected.max(scene.dt),
        };
        if !fits {
            return Err(CaseError::Resume(format!(
                "the checkpoint is at step {} and t = {}, which does not fit this scene (dt = {}, \
                 {last} steps)",
                sim.step, sim.t, scene.dt
            )));
        }
        while pending.peek().is_some_and(|t| *t <= due(sim.t)) {
            pending.next();
        }
    } else {
        emit(&mut case, &sim, None, false, sink)?;
        while pending.peek().is_some_and(|t| *t <= 0.0) {
            pending.next();
            for t in case.snapshot(&sim)? {
                sink.table(&t)?;
            }
        }
    }
    tally.penetrations = tally.penetrations.max(sim.wall_penetrations());
    tally.intrusion = tally.intrusion.max(sim.wall_intrusion());
    let mut failure = None;
    let mut segment_steps = 0usize;
    let mut interrupted = false;
    let mut stop_pending = false;
    let mut bound = None;
    let mut k = sim.step;
    let speed_limit = scene.limits.speed_ratio() * velocity_scale;
    loop {
        k += 1;
        // The fastest fluid particle (the first of equals: the same on any thread count).
        let (fastest, u_max) = sim.particles.velocities[..sim.fluid_len()]
            .iter()
            .map(|u| u.length())
            .enumerate()
            .fold(
                (0, 0.0),
                |(i, a), (j, b)| if b > a { (j, b) } else { (i, a) },
            );
        if speed_limit > 0.0 && u_max > speed_limit {
            failure = Some(StepError::SpeedRunaway {
                step: sim.step,
                t: sim.t,
                particle: sim.ids().get(fastest).map_or(fastest, |&id| id as usize),
                speed: u_max,
                scale: velocity_scale,
                limit: scene.limits.speed_ratio(),
            });
            break;
        }
        let (dt, short, is_last) = match auto {
            None => {
                if k > last {
                    break;
                }
                let short = k == last && rest.is_some();
                let dt = if short {
                    rest.expect("short step")
                } else {
                    scene.dt
                };
                (dt, short, k == last)
            }
            Some(a) => {
                let remaining = scene.t_end - sim.t;
                if remaining <= 1e-9 * scene.dt {
                    break;
                }
                let (dt, b) = a.choose(scene.dt, h, u_max, nu, gravity);
                bound = Some(b);
                bound_now.set(bound);
                if dt < COLLAPSE_FRACTION * tally.dt_max {
                    failure = Some(StepError::TimeStepCollapse {
                        step: sim.step,
                        t: sim.t,
                        dt,
                        largest: tally.dt_max,
                        speed: u_max,
                        bound: b,
                    });
                    break;
                }
                end_step(remaining, dt)
            }
        };
        let report = match case.advance(&mut sim, &mut integrator, dt) {
            Ok(r) => r,
            Err(mut e) => {
                if let StepError::BlowUp { dt_bound, .. } = &mut e {
                    *dt_bound = bound;
                }
                failure = Some(e);
                break;
            }
        };
        tally.steps += 1;
        segment_steps += 1;
        tally.dt_min = if tally.dt_min > 0.0 {
            tally.dt_min.min(dt)
        } else {
            dt
        };
        tally.dt_max = tally.dt_max.max(dt);
        tally.displacement = tally.displacement.max(report.max_displacement);
        tally.guarded += report.wall_guarded;
        tally.contacts += report.wall_contacts;
        tally.iterations += report.solve.iterations as f64;
        tally.phases.accumulate(&report.phases);
        let snap = pending.peek().is_some_and(|t| *t <= due(sim.t));
        if k % every == 0 || is_last || snap || report.wall_penetrations > 0 {
            emit(&mut case, &sim, Some(&report), short, sink)?;
            tally.penetrations = tally.penetrations.max(sim.wall_penetrations());
            tally.intrusion = tally.intrusion.max(sim.wall_intrusion());
            tally.speed = tally.speed.max(sim.max_speed());
            while pending.peek().is_some_and(|t| *t <= due(sim.t)) {
                pending.next();
                for t in case.snapshot(&sim)? {
                    sink.table(&t)?;
                }
            }
        }
        // A stop asked for is carried out at the first step after which the linear solver
        // keeps nothing it would use (an AMG hierarchy is rebuilt at least every 10 solves):
        // the run resumed from its checkpoint then goes on to the same bits as the run that
        // was not stopped. Periodic checkpoints (and the last step's) are written when due,
        // and the solver starts afresh after them, as a run resumed from them will.
        stop_pending |= !is_last
            && control
                .stop
                .is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed));
        let stop = stop_pending && sim.solver_keeps_nothing();
        let periodic = control
            .checkpoint_every
            .is_some_and(|n| k % n.max(1) == 0 || is_last);
        if stop || periodic {
            tally.records = records.get();
            tally.density_max = density_max.get();
            let mut c = sim.checkpoint(&control.checkpoint_meta);
            c.state = run_state(&tally, case.save_state());
            sink.checkpoint(&c)?;
            sim.invalidate_solver_setup();
        }
        sink.progress(k, sim.t, scene.t_end);
        if stop {
            interrupted = true;
            break;
        }
    }
    let finish = case.finish(&sim)?;
    // The tables of the end of the run: an interrupted run has not ended.
    if !interrupted {
        for t in &finish.tables {
            sink.table(t)?;
        }
    }
    let mut results = finish.results;
    for (name, value) in [
        ("reached_t", sim.t),
        ("steps", sim.step as f64),
        ("max_wall_penetrations", tally.penetrations as f64),
        ("max_wall_intrusion_dx", tally.intrusion / scene.dx),
        ("max_speed", tally.speed.max(sim.max_speed())),
        ("max_displacement", tally.displacement),
        ("wall_guarded", tally.guarded as f64),
        ("wall_contacts", tally.contacts as f64),
        ("kinetic_energy", {
            let p = &sim.particles;
            0.5 * p.masses[..counts.0]
                .iter()
                .zip(&p.velocities[..counts.0])
                .map(|(m, u)| m * u.length_squared())
                .sum::<f64>()
        }),
        (
            "solver_iterations_mean",
            tally.iterations / tally.steps.max(1) as f64,
        ),
        ("wall_seconds", clock.elapsed().as_secs_f64()),
        ("dt_min", tally.dt_min),
        ("dt_max", tally.dt_max),
        (
            "completed",
            if failure.is_none() && !interrupted {
                1.0
            } else {
                0.0
            },
        ),
        ("density_error_max", density_max.get()),
        (
            "max_speed_ratio",
            tally.speed.max(sim.max_speed()) / velocity_scale,
        ),
    ] {
        results.insert(name.to_string(), value);
    }
    let checks = run_checks(
        scene,
        scheme,
        case.as_ref(),
        &results,
        sim.t,
        failure.as_ref().map(|e| e.to_string()).as_deref(),
    );
    Ok(SchemeRun {
        scheme,
        particles: counts,
        carved,
        steps_taken: tally.steps,
        segment_steps,
        step: sim.step,
        t: sim.t,
        wall_s: clock.elapsed().as_secs_f64(),
        phases: tally.phases,
        results,
        checks,
        failure,
        interrupted,
    })
}

/// The checks of one scheme's run that reached `t` with `results`: the case's built-in ones,
/// the scene's `[[check]]`s and, for a run that stopped at a failed step (`failure`, its
/// error), "run completes".
pub fn run_checks<D: Dim>(
    scene: &Scene,
    scheme: SchemeKind,
    case: &dyn Case<D>,
    results: &Results,
    t: f64,
    failure: Option<&str>,
) -> Vec<Check> {
    let label = format!("{} t={t:.4}", scheme.name());
    let mut checks = case.checks(scheme, &label, results);
    checks.extend(scene_checks(scene, scheme, &label, results));
    if let Some(e) = failure {
        checks.push(run_completes_check(scene, scheme, scheme.name(), e));
    }
    checks
}

/// The checks a scene declares in `[[check]]`, on one scheme's results.
fn scene_checks(scene: &Scene, scheme: SchemeKind, label: &str, results: &Results) -> Vec<Check> {
    scene
        .check
        .iter()
        .filter(|c| c.schemes.is_empty() || c.schemes.contains(&scheme))
        .flat_map(|c| {
            let value = results.get(&c.quantity).copied().unwrap_or(f64::NAN);
            let source = c.source.clone().unwrap_or_else(|| "scene [[check]]".into());
            let name = format!("{label} {}", c.quantity);
            c.max
                .map(|m| Check::at_most(scene.case.name(), name.clone(), value, m, source.clone()))
                .into_iter()
                .chain(c.min.map(|m| {
                    Check::at_least(scene.case.name(), name.clone(), value, m, source.clone())
                }))
                .map(|mut k| {
                    k.known_failure = c.known_failure.clone();
                    k
                })
        })
        .collect()
}

/// The check "`<scheme>` run completes" for a run that stopped at `error`: failing, and a
/// known failure when the scene declares its `completed` check one for this scheme.
pub fn run_completes_check(scene: &Scene, scheme: SchemeKind, label: &str, error: &str) -> Check {
    let mut c = Check::new(
        scene.case.name(),
        format!("{label} run completes"),
        0.0,
        1.0,
        0.0,
        error,
    );
    c.known_failure = scene
        .check
        .iter()
        .filter(|k| k.quantity == "completed")
        .filter(|k| k.schemes.is_empty() || k.schemes.contains(&scheme))
        .find_map(|k| k.known_failure.clone());
    c
}

/// A sink that keeps everything in memory: records by column name, tables, checkpoints. For
/// tests and for programs that post-process a run themselves.
#[derive(Default)]
pub struct MemorySink {
    /// Column names.
    pub columns: Vec<String>,
    /// Records, one value per column.
    pub records: Vec<Vec<f64>>,
    /// Tables in the order they were handed out.
    pub tables: Vec<Table>,
    /// Checkpoints in the order they were handed out.
    pub checkpoints: Vec<Checkpoint>,
}

impl MemorySink {
    /// The values of column `name` over the records (empty if there is no such column).
    pub fn column(&self, name: &str) -> Vec<f64> {
        match self.columns.iter().position(|c| c == name) {
            Some(k) => self.records.iter().map(|r| r[k]).collect(),
            None => Vec::new(),
        }
    }

    /// The value of column `name` in the last record.
    pub fn last(&self, name: &str) -> f64 {
        self.column(name).last().copied().unwrap_or(f64::NAN)
    }
}

impl RunSink for MemorySink {
    fn begin(&mut self, columns: &[Column]) -> std::io::Result<()> {
        self.columns = columns.iter().map(|c| c.name.clone()).collect();
        Ok(())
    }
    fn record(&mut self, values: &[f64], _: &dyn Frame, _: bool) -> std::io::Result<()> {
        self.records.push(values.to_vec());
        Ok(())
    }
    fn table(&mut self, table: &Table) -> std::io::Result<()> {
        self.tables.push(table.clone());
        Ok(())
    }
    fn checkpoint(&mut self, checkpoint: &Checkpoint) -> std::io::Result<()> {
        self.checkpoints.push(checkpoint.clone());
        Ok(())
    }
}

/// Steps over which the automatic step spreads what is left of the run: within the last
/// `END_STEPS` steps it takes equal steps to `t_end` (see `end_step`).
pub const END_STEPS: usize = 10;

/// The automatic step's length and whether it is the last, with `remaining` to `t_end` and the
/// limits' step `dt`: `dt` while more than [`END_STEPS`] such steps remain, then
/// `remaining / n` with `n = ⌈remaining / dt⌉`. A projection's pressure scales as `1/Δt`, so a
/// last step cut to a sliver (or halved) leaves a pressure transient in the final state; equal
/// steps change Δt by at most `1/END_STEPS` once the limits are steady.
fn end_step(remaining: f64, dt: f64) -> (f64, bool, bool) {
    if remaining <= dt * (1.0 + 1e-6) {
        return (remaining, false, true);
    }
    let n = (remaining / dt).ceil();
    if n <= END_STEPS as f64 {
        (remaining / n, false, false)
    } else {
        (dt, false, false)
    }
}
