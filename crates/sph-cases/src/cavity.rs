//! Section 6 of the paper: the lid-driven cavity.
//!
//! Unit square (2D) or cube (3D) of fluid on the lattice `(i + ½) dx`, surrounded by fixed dummy
//! wall particles on the same lattice ([`WallModel::DummyParticles`]); the wall particles above
//! `y = 1` over the cavity's width (the lid; the corner blocks stay at rest) move with `(U, 0, 0)`;
//! the scene's `wall_condition` picks the [`WallCondition`](sph_integrators::WallCondition).
//! Effects: viscosity
//! `ν = U·1/Re`, plus whatever the scene declares (shifting); no free surface, so the pressure
//! carries the mean-zero gauge.
//!
//! Measurements:
//! * kinetic energy `½ Σ m u²` over the fluid, and a steady-state time (see [`steady_time`]);
//! * the density error of paper Eq. (31): `ρ̂_a = Σ_b m_b W(r_a − r_b)` on a uniform probe
//!   array over the cavity (particles `b`: fluid and wall), RMS of `ρ̂_a/ρ₀ − 1` (the paper's)
//!   and of `ρ̂_a(t)/ρ̂_a(0) − 1` (relative to the initial lattice, which removes the kernel's
//!   lattice-sum bias: 1 % for Wendland C2 at h = 1.3 dx);
//! * centreline profiles `u(0.5, y)` and `v(x, 0.5)` at the Ghia et al. (1982) points, by
//!   Shepard interpolation over the fluid and the wall particles' no-slip (mirrored) velocity,
//!   compared with `cases/reference/ghia_*.csv` (the Re 400 point v(0.9063) is excluded: a
//!   suspected misprint; points on the walls are excluded: they are boundary conditions).

use crate::reference::References;
use crate::{CaseError, Check, Scene};
use sph_core::{Dim, ParticleSet, VectorOps};
use sph_integrators::{
    Checkpoint, DetFStats, Frame, Integrator, Scheme, SchemeKind, SimConfig, Simulation, Viscosity,
    WallModel, Walls,
};
use sph_kernels::Kernel;
use sph_neighbors::{CellGrid, NeighborList, NeighborSearch};
use sph_operators::{SphContext, density_at_points};

/// The cavity's initial state.
pub struct CavitySetup<D: Dim> {
    /// Fluid particles followed by wall particles.
    pub particles: ParticleSet<D>,
    /// Numerical configuration (viscosity from the Reynolds number).
    pub config: SimConfig,
    /// The walls.
    pub walls: Walls<D>,
}

/// Builds the cavity of `scene` (`scene.dim` must be `D::DIM`, `scene.cavity` set).
pub fn setup<D: Dim>(scene: &Scene) -> Result<CavitySetup<D>, CaseError> {
    let spec = scene.cavity.as_ref().ok_or_else(|| CaseError::Invalid {
        scene: "lid_driven_cavity".into(),
        field: "cavity",
        message: "section missing".into(),
    })?;
    let dx = scene.dx;
    let n = (1.0 / dx).round() as i64;
    let mut config = scene.sim_config();
    config.effects.viscosity = Some(Viscosity {
        nu: spec.lid_speed.abs() / spec.reynolds,
    });
    let support = config.kernel.build::<D>(config.h).support_radius();
    let layers = spec
        .wall_layers
        .unwrap_or_else(|| (support / dx - 1e-9).ceil() as usize) as i64;
    let mut fluid = Vec::new();
    let mut wall = Vec::new();
    let mut wall_u = Vec::new();
    let mut mirror = Vec::new();
    let lo = -layers;
    let hi = n + layers;
    let count = (hi - lo) as usize;
    let total = count.pow(D::DIM as u32);
    for flat in 0..total {
        let mut rem = flat;
        let idx: Vec<i64> = (0..D::DIM)
            .map(|_| {
                let k = (rem % count) as i64 + lo;
                rem /= count;
                k
            })
            .collect();
        let x = D::Vector::from_fn(|k| (idx[k] as f64 + 0.5) * dx);
        if idx.iter().all(|&k| (0..n).contains(&k)) {
            fluid.push(x);
        } else {
            wall.push(x);
            mirror.push(D::Vector::from_fn(|k| {
                if (0..n).contains(&idx[k]) { 1.0 } else { -1.0 }
            }));
            // The lid spans the cavity's width only: the corner blocks beyond the side walls
            // are at rest (they continue the side walls), so no wall particle drags the fluid
            // into a side wall.
            let lid = idx[1] >= n
                && (0..D::DIM)
                    .filter(|&k| k != 1)
                    .all(|k| (0..n).contains(&idx[k]));
            wall_u.push(D::Vector::from_fn(|k| {
                if lid && k == 0 { spec.lid_speed } else { 0.0 }
            }));
        }
    }
    let first = fluid.len();
    fluid.extend(wall);
    let particles = ParticleSet::<D>::from_positions(fluid, dx.powi(D::DIM as i32), config.rho0);
    let walls = Walls {
        model: WallModel::DummyParticles,
        condition: spec.wall_condition,
        first,
        velocity: wall_u,
        mirror,
        lo: D::Vector::ZERO,
        hi: D::Vector::from_fn(|_| 1.0),
    };
    Ok(CavitySetup {
        particles,
        config,
        walls,
    })
}

/// One time-series record of a cavity run.
#[derive(Clone, Debug, PartialEq)]
pub struct CavityRecord {
    /// Scheme.
    pub scheme: SchemeKind,
    /// Steps completed.
    pub step: usize,
    /// Time.
    pub t: f64,
    /// `½ Σ m u²` over the fluid.
    pub kinetic_energy: f64,
    /// RMS of `ρ̂/ρ₀ − 1` over the probe array (paper Eq. 31).
    pub density_error_rms: f64,
    /// RMS of `ρ̂(t)/ρ̂(0) − 1` over the probe array.
    pub density_change_rms: f64,
    /// Largest `|ρ̂/ρ₀ − 1|`.
    pub density_error_max: f64,
    /// Mean fluid pressure (the gauge holds it at 0).
    pub mean_pressure: f64,
    /// `max p − min p` over the fluid.
    pub pressure_range: f64,
    /// Fluid particles outside the cavity.
    pub wall_penetrations: usize,
    /// How far the furthest fluid particle lies outside the cavity (0 if none does).
    pub wall_intrusion: f64,
    /// Solver iterations of the last step (0 for the initial record).
    pub solver_iterations: usize,
    /// max |∇·u| after the last projection.
    pub max_div_u: f64,
    /// Gauge multiplier of the last step.
    pub gauge_multiplier: f64,
    /// det F of the last step.
    pub det_f: Option<DetFStats>,
    /// Wall time of the last step.
    pub step_seconds: f64,
    /// Deviation of the centreline profiles from Ghia et al. at this time (2D, tabulated Re).
    pub ghia: Option<GhiaDeviation>,
}

/// The density-error field at one time, on the probe array.
#[derive(Clone, Debug, PartialEq)]
pub struct DensitySnapshot {
    /// Time.
    pub t: f64,
    /// Probe positions (`[x, y, z]`).
    pub probes: Vec<[f64; 3]>,
    /// `ρ̂/ρ₀ − 1` at each probe.
    pub error: Vec<f64>,
}

/// Centreline velocity profiles at Ghia's points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Profiles {
    /// `(y, u(0.5, y), u_Ghia)` (2D; in 3D the mid-plane `z = 0.5`).
    pub u_vertical: Vec<(f64, f64, f64)>,
    /// `(x, v(x, 0.5), v_Ghia)`.
    pub v_horizontal: Vec<(f64, f64, f64)>,
}

/// Deviation of the profiles from Ghia et al.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GhiaDeviation {
    /// RMS of `u − u_Ghia`.
    pub u_rms: f64,
    /// Max of `|u − u_Ghia|`.
    pub u_max: f64,
    /// RMS of `v − v_Ghia`.
    pub v_rms: f64,
    /// Max of `|v − v_Ghia|`.
    pub v_max: f64,
}

/// Everything a cavity run produced.
#[derive(Clone, Debug)]
pub struct CavityRun {
    /// Time series.
    pub records: Vec<CavityRecord>,
    /// Density-error fields at the scene's snapshot times (and the end).
    pub snapshots: Vec<DensitySnapshot>,
    /// Final centreline profiles (with the Ghia values where the Reynolds number is tabulated).
    pub profiles: Profiles,
    /// Deviation from Ghia et al. (2D, Re ∈ {100, 400, 1000, 3200, 5000, 7500, 10000}).
    pub ghia: Option<GhiaDeviation>,
    /// Steady-state time by the kinetic-energy criterion, if reached.
    pub steady_time: Option<f64>,
    /// Particle count (fluid, walls).
    pub particles: (usize, usize),
}

impl CavityRun {
    /// The most fluid particles outside the cavity at any record (a particle that crosses a
    /// wall and comes back counts).
    pub fn max_penetrations(&self) -> usize {
        self.records
            .iter()
            .map(|r| r.wall_penetrations)
            .max()
            .unwrap_or(0)
    }

    /// The deepest any fluid particle lay outside the cavity at any record.
    pub fn max_intrusion(&self) -> f64 {
        self.records
            .iter()
            .map(|r| r.wall_intrusion)
            .fold(0.0, f64::max)
    }
}

/// Probe array and scratch of the Eq. (31) density measurement.
struct DensityProbe<D: Dim> {
    probes: Vec<D::Vector>,
    grid: CellGrid<D>,
    lists: NeighborList,
    rho: Vec<f64>,
    rho_initial: Vec<f64>,
}

impl<D: Dim> DensityProbe<D> {
    fn new(spacing: f64) -> Self {
        let m = (1.0 / spacing).round().max(1.0) as usize;
        let d = 1.0 / m as f64;
        let total = m.pow(D::DIM as u32);
        let probes = (0..total)
            .map(|flat| {
                let mut rem = flat;
                D::Vector::from_fn(|_| {
                    let k = rem % m;
                    rem /= m;
                    (k as f64 + 0.5) * d
                })
            })
            .collect();
        Self {
            probes,
            grid: CellGrid::new(),
            lists: NeighborList::new(),
            rho: vec![0.0; total],
            rho_initial: Vec::new(),
        }
    }

    /// Samples ρ̂ and returns (rms vs ρ₀, rms vs initial, max vs ρ₀).
    fn measure(&mut self, sim: &Simulation<D>) -> (f64, f64, f64) {
        let p = &sim.particles;
        let r = sim.support_radius();
        self.grid
            .build(&p.positions, r)
            .expect("positions were checked finite by the step");
        self.grid.query(&self.probes, &mut self.lists);
        density_at_points(
            &self.probes,
            &self.lists,
            &p.positions,
            &p.masses,
            sim.kernel(),
            &mut self.rho,
        );
        if self.rho_initial.is_empty() {
            self.rho_initial = self.rho.clone();
        }
        let rho0 = sim.config().rho0;
        let n = self.rho.len() as f64;
        let (mut s0, mut s1, mut mx) = (0.0, 0.0, 0.0_f64);
        for (r, r0) in self.rho.iter().zip(&self.rho_initial) {
            let e = r / rho0 - 1.0;
            s0 += e * e;
            mx = mx.max(e.abs());
            let c = r / r0 - 1.0;
            s1 += c * c;
        }
        ((s0 / n).sqrt(), (s1 / n).sqrt(), mx)
    }

    fn snapshot(&self, t: f64, rho0: f64) -> DensitySnapshot {
        DensitySnapshot {
            t,
            probes: self.probes.iter().map(|x| x.to_array3()).collect(),
            error: self.rho.iter().map(|r| r / rho0 - 1.0).collect(),
        }
    }
}

fn record<D: Dim>(
    sim: &Simulation<D>,
    scheme: SchemeKind,
    re: f64,
    refs: &References,
    probe: &mut DensityProbe<D>,
    report: Option<&sph_integrators::StepReport>,
) -> CavityRecord {
    let p = &sim.particles;
    let nf = sim.fluid_len();
    let ke = 0.5
        * p.masses[..nf]
            .iter()
            .zip(&p.velocities[..nf])
            .map(|(m, u)| m * u.length_squared())
            .sum::<f64>();
    let (rms, change, max) = probe.measure(sim);
    let pf = &p.pressures[..nf];
    let mean_p = pf.iter().sum::<f64>() / nf as f64;
    let (pmin, pmax) = pf
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    CavityRecord {
        scheme,
        step: sim.step,
        t: sim.t,
        kinetic_energy: ke,
        density_error_rms: rms,
        density_change_rms: change,
        density_error_max: max,
        mean_pressure: mean_p,
        pressure_range: pmax - pmin,
        wall_penetrations: sim.wall_penetrations(),
        wall_intrusion: sim.wall_intrusion(),
        solver_iterations: report.map_or(0, |r| r.solve.iterations),
        max_div_u: report.map_or(0.0, |r| r.max_div_u),
        gauge_multiplier: report.map_or(0.0, |r| r.gauge_multiplier),
        det_f: report.and_then(|r| r.det_f),
        step_seconds: report.map_or(0.0, |r| r.seconds),
        ghia: (D::DIM == 2)
            .then(|| ghia_deviation(&profiles(sim, re, refs), re))
            .flatten(),
    }
}

/// A receiver of checkpoints (the caller writes them where it likes).
pub type SaveCheckpoint<'a> = dyn FnMut(&Checkpoint) -> std::io::Result<()> + 'a;

/// How a cavity run starts and saves its state ([`run_with`]).
#[derive(Default)]
pub struct RunControl<'a> {
    /// Continue from this checkpoint (of the same scene and scheme) instead of t = 0. The
    /// initial record is not observed again; the density change is still measured against the
    /// initial lattice.
    pub resume: Option<&'a Checkpoint>,
    /// Hand a checkpoint to `save` every this many steps and after the last step.
    pub checkpoint_every: Option<usize>,
    /// Receives the checkpoints.
    pub save: Option<&'a mut SaveCheckpoint<'a>>,
}

/// Runs one scheme on the cavity of `scene` to `scene.t_end`, calling `observe` with every
/// record and the particle state as soon as they exist. A failing step ends the run with an
/// error after everything observed so far has been handed out.
pub fn run<D: Dim>(
    scene: &Scene,
    scheme: SchemeKind,
    refs: &References,
    observe: &mut dyn FnMut(&CavityRecord, &dyn Frame) -> std::io::Result<()>,
) -> Result<CavityRun, CaseError> {
    run_with::<D>(scene, scheme, refs, RunControl::default(), observe)
}

/// [`run`], resuming from and saving checkpoints as `control` says (runs longer than a
/// session). The returned records start at the resumed step.
pub fn run_with<D: Dim>(
    scene: &Scene,
    scheme: SchemeKind,
    refs: &References,
    mut control: RunControl<'_>,
    observe: &mut dyn FnMut(&CavityRecord, &dyn Frame) -> std::io::Result<()>,
) -> Result<CavityRun, CaseError> {
    let spec = scene.cavity.clone().expect("validated cavity scene");
    let s = setup::<D>(scene)?;
    let counts = (s.walls.first, s.particles.len() - s.walls.first);
    let mut sim = Simulation::with_walls(s.particles, s.config, s.walls)
        .map_err(|e| CaseError::Walls(e.to_string()))?;
    let mut integrator = Scheme::new(scheme);
    let mut probe = DensityProbe::<D>::new(spec.probe_spacing.unwrap_or(scene.dx));
    let steps = (scene.t_end / scene.dt - 1e-9).ceil().max(1.0) as usize;
    let every = spec.sample_every.unwrap_or((steps / 400).max(1));
    let rho0 = sim.config().rho0;
    let mut records = Vec::new();
    let mut snapshots = Vec::new();
    let mut pending: Vec<f64> = spec.snapshots.clone();
    pending.sort_by(f64::total_cmp);
    let mut pending = pending.into_iter().peekable();
    if let Some(c) = control.resume {
        probe.measure(&sim); // the initial lattice's ρ̂, for density_change_rms
        sim.restore(c)
            .map_err(|e| CaseError::Resume(e.to_string()))?;
        while pending
            .peek()
            .is_some_and(|t| *t <= sim.t + 1e-9 * scene.dt)
        {
            pending.next();
        }
    } else {
        let r0 = record(&sim, scheme, spec.reynolds, refs, &mut probe, None);
        observe(&r0, &sim)?;
        records.push(r0);
        while pending.peek().is_some_and(|t| *t <= 0.0) {
            pending.next();
            snapshots.push(probe.snapshot(0.0, rho0));
        }
    }
    let first = sim.step + 1;
    for k in first..=steps {
        let report = integrator
            .step(&mut sim, scene.dt)
            .map_err(|source| CaseError::Step {
                scheme: scheme.name(),
                source,
            })?;
        let snap = pending
            .peek()
            .is_some_and(|t| *t <= sim.t + 1e-9 * scene.dt);
        if k % every == 0 || k == steps || snap || report.wall_penetrations > 0 {
            let r = record(&sim, scheme, spec.reynolds, refs, &mut probe, Some(&report));
            observe(&r, &sim)?;
            records.push(r);
            while pending
                .peek()
                .is_some_and(|t| *t <= sim.t + 1e-9 * scene.dt)
            {
                pending.next();
                snapshots.push(probe.snapshot(sim.t, rho0));
            }
        }
        if let (Some(n), Some(save)) = (control.checkpoint_every, control.save.as_mut())
            && (k % n.max(1) == 0 || k == steps)
        {
            save(&sim.checkpoint())?;
        }
    }
    if records.is_empty() {
        // Resumed at (or past) the end: one record of the restored state.
        let r = record(&sim, scheme, spec.reynolds, refs, &mut probe, None);
        observe(&r, &sim)?;
        records.push(r);
    }
    if snapshots.last().is_none_or(|s| s.t < sim.t) {
        snapshots.push(probe.snapshot(sim.t, rho0));
    }
    let profiles = profiles(&sim, spec.reynolds, refs);
    let ghia = (D::DIM == 2)
        .then(|| ghia_deviation(&profiles, spec.reynolds))
        .flatten();
    Ok(CavityRun {
        steady_time: steady_time(&records, 1.0, 1e-3),
        records,
        snapshots,
        profiles,
        ghia,
        particles: counts,
    })
}

/// Earliest record time `t` such that for every later record at `t' ≥ t + window`,
/// `|KE(t') − KE(t' − window)| / KE(t') < tol` (relative kinetic-energy change per `window`).
pub fn steady_time(records: &[CavityRecord], window: f64, tol: f64) -> Option<f64> {
    let ke_at = |t: f64| {
        // Record at or just before t.
        let k = records.partition_point(|r| r.t <= t + 1e-12);
        records[k.saturating_sub(1)].kinetic_energy
    };
    let mut steady_since: Option<f64> = None;
    for r in records.iter().filter(|r| r.t >= window) {
        let change = (r.kinetic_energy - ke_at(r.t - window)).abs() / r.kinetic_energy.max(1e-300);
        if change < tol {
            steady_since.get_or_insert(r.t - window);
        } else {
            steady_since = None;
        }
    }
    steady_since
}

/// Centreline profiles at Ghia's coordinates (the mid-plane `z = 0.5` in 3D), normalised by
/// the lid speed: Shepard interpolation over the fluid particles and the wall particles'
/// no-slip velocity `2u_wall − ũ_w` (the field a mirror ghost would carry).
pub fn profiles<D: Dim>(sim: &Simulation<D>, re: f64, refs: &References) -> Profiles {
    let p = &sim.particles;
    let nf = sim.fluid_len();
    let walls = sim.walls().expect("cavity has walls");
    let mut grid = CellGrid::<D>::new();
    grid.build(&p.positions, sim.support_radius())
        .expect("finite positions");
    let mut lists = NeighborList::new();
    grid.query(&p.positions, &mut lists);
    let volumes: Vec<f64> = p
        .masses
        .iter()
        .zip(&p.densities)
        .map(|(m, r)| m / r)
        .collect();
    let ctx = SphContext::new(&p.positions, &volumes, &lists, sim.kernel());
    let mut u = p.velocities.clone();
    walls.no_slip_velocity(&ctx, &p.velocities, &mut u[nf..]);
    let lid = walls
        .velocity
        .iter()
        .map(|v| v.get(0).abs())
        .fold(0.0, f64::max);
    let at = |a: f64, b: f64| D::Vector::from_fn(|k| [a, b, 0.5][k]);
    let rows_u = refs.ghia_u_vertical(re);
    let rows_v = refs.ghia_v_horizontal(re);
    let points: Vec<D::Vector> = rows_u
        .iter()
        .map(|&(y, _)| at(0.5, y))
        .chain(rows_v.iter().map(|&(x, _)| at(x, 0.5)))
        .collect();
    grid.query(&points, &mut lists);
    let sample = |a: usize| {
        let x = points[a];
        let (mut sw, mut su) = (0.0, D::Vector::ZERO);
        for &j in lists.row(a) {
            let j = j as usize;
            let w = sim.kernel().w((x - p.positions[j]).length()) * volumes[j];
            sw += w;
            su += u[j] * w;
        }
        if sw > 0.0 {
            su * (1.0 / (sw * lid))
        } else {
            D::Vector::ZERO
        }
    };
    let u_vertical = rows_u
        .iter()
        .enumerate()
        .map(|(a, &(y, g))| (y, sample(a).get(0), g))
        .collect();
    let v_horizontal = rows_v
        .iter()
        .enumerate()
        .map(|(a, &(x, g))| (x, sample(rows_u.len() + a).get(1), g))
        .collect();
    Profiles {
        u_vertical,
        v_horizontal,
    }
}

/// RMS and max deviation from Ghia et al., over the interior points (walls excluded; the
/// Re 400 v(0.9063) point excluded). `None` if the Reynolds number is not tabulated.
pub fn ghia_deviation(profiles: &Profiles, re: f64) -> Option<GhiaDeviation> {
    let interior = |c: f64| c > 1e-9 && c < 1.0 - 1e-9;
    let stats = |rows: &[(f64, f64, f64)], skip: Option<f64>| {
        let d: Vec<f64> = rows
            .iter()
            .filter(|(c, _, g)| {
                interior(*c) && g.is_finite() && skip.is_none_or(|s| (c - s).abs() > 1e-6)
            })
            .map(|(_, v, g)| v - g)
            .collect();
        let rms = (d.iter().map(|e| e * e).sum::<f64>() / d.len().max(1) as f64).sqrt();
        let max = d.iter().fold(0.0_f64, |m, e| m.max(e.abs()));
        (rms, max, d.len())
    };
    let (u_rms, u_max, nu) = stats(&profiles.u_vertical, None);
    let skip = (re == 400.0).then_some(0.9063);
    let (v_rms, v_max, nv) = stats(&profiles.v_horizontal, skip);
    (nu > 0 && nv > 0).then_some(GhiaDeviation {
        u_rms,
        u_max,
        v_rms,
        v_max,
    })
}

/// Checks of one cavity run: zero wall penetrations, a pressure without constant drift
/// (`|mean p| ≤ 1e-6 (max p − min p)` at every record), and — in 2D at a tabulated Reynolds
/// number — RMS and max deviation from Ghia et al. within the scene's tolerances.
pub fn checks(case: &str, scene: &Scene, scheme: SchemeKind, run: &CavityRun) -> Vec<Check> {
    let last = run.records.last().expect("at least the initial record");
    let label = format!("{} t={:.2}", scheme.name(), last.t);
    let mut out = vec![Check::new(
        case,
        format!("{label} wall penetrations (max over records)"),
        run.max_penetrations() as f64,
        0.0,
        0.0,
        "walls must hold",
    )];
    let drift = run
        .records
        .iter()
        .filter(|r| r.pressure_range > 0.0)
        .map(|r| r.mean_pressure.abs() / r.pressure_range)
        .fold(0.0, f64::max);
    out.push(Check::new(
        case,
        format!("{label} max |mean p| / (p_max − p_min)"),
        drift,
        0.0,
        1e-6,
        "mean-zero gauge: no constant drift",
    ));
    if let (Some(g), Some(spec)) = (run.ghia, scene.cavity.as_ref())
        && spec.check_ghia != Some(false)
    {
        let [rms, max] = spec.ghia_tolerance.unwrap_or([0.02, 0.05]);
        let re = spec.reynolds;
        for (what, value, tol) in [
            ("u(0.5, y) RMS", g.u_rms, rms),
            ("u(0.5, y) max", g.u_max, max),
            ("v(x, 0.5) RMS", g.v_rms, rms),
            ("v(x, 0.5) max", g.v_max, max),
        ] {
            out.push(Check::new(
                case,
                format!("{label} Re={re} {what} dev."),
                value,
                0.0,
                tol,
                "Ghia, Ghia & Shin (1982) Tables I-II",
            ));
        }
    }
    out
}
