use sph_pressure::SolveInfo;
use std::time::Instant;

/// min / mean / max of `det F` over the step's non-free-surface particles, where `F` is the
/// renormalised SPH deformation gradient of the step's displacement `xⁿ⁺¹ − xⁿ` (paper Eq. 26).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DetFStats {
    /// Minimum.
    pub min: f64,
    /// Mean.
    pub mean: f64,
    /// Maximum.
    pub max: f64,
}

/// A pass of a time step. [`PhaseTimes`] records which passes ran and how long each took, so a
/// run can show that it computed only the effects its scene declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Phase {
    /// Neighbour search (index build and query), once per configuration.
    Neighbors,
    /// Volumes and kernel-gradient renormalisation matrices.
    Renormalisation,
    /// Free-surface detection (`∇·r` and the Dirichlet flags).
    FreeSurface,
    /// Viscous acceleration (with the walls' no-slip velocity).
    Viscosity,
    /// Particle-scale dissipation (`[effects] hyperviscosity`).
    Hyperviscosity,
    /// Body force.
    Gravity,
    /// Wall boundary data: the velocity the projection reads at the wall particles and the
    /// Neumann data of their pressure rows.
    WallData,
    /// The pressure equation's source: `∇·u*` (PPE) or `A = I + Δt∇u*` and `det A − 1` (DG).
    Source,
    /// Matrix and right-hand side assembly (fluid rows and wall rows).
    Assembly,
    /// Preconditioner set-up (Jacobi, ILU(0) factorisation or the AMG hierarchy).
    PrecondSetup,
    /// Krylov iterations (or the direct solve).
    Solve,
    /// Pressure gradient and velocity correction `uⁿ⁺¹ = u* − Δt∇p/ρ`.
    Correction,
    /// Particle shifting.
    Shifting,
    /// Per-step diagnostics (`det F`, `max |∇·u|`).
    Diagnostics,
}

impl Phase {
    /// Every phase, in the order a step runs them.
    pub const ALL: [Phase; 14] = [
        Phase::Neighbors,
        Phase::Renormalisation,
        Phase::FreeSurface,
        Phase::Viscosity,
        Phase::Hyperviscosity,
        Phase::Gravity,
        Phase::WallData,
        Phase::Source,
        Phase::Assembly,
        Phase::PrecondSetup,
        Phase::Solve,
        Phase::Correction,
        Phase::Shifting,
        Phase::Diagnostics,
    ];

    /// Name used in records (`snake_case`).
    pub fn name(self) -> &'static str {
        match self {
            Phase::Neighbors => "neighbors",
            Phase::Renormalisation => "renormalisation",
            Phase::FreeSurface => "free_surface",
            Phase::Viscosity => "viscosity",
            Phase::Hyperviscosity => "hyperviscosity",
            Phase::Gravity => "gravity",
            Phase::WallData => "wall_data",
            Phase::Source => "source",
            Phase::Assembly => "assembly",
            Phase::PrecondSetup => "precond_setup",
            Phase::Solve => "solve",
            Phase::Correction => "correction",
            Phase::Shifting => "shifting",
            Phase::Diagnostics => "diagnostics",
        }
    }
}

/// Wall time and run count of each [`Phase`] in one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    seconds: [f64; Phase::ALL.len()],
    runs: [u32; Phase::ALL.len()],
}

impl PhaseTimes {
    /// Adds one run of `phase` that started at `since`.
    pub(crate) fn add(&mut self, phase: Phase, since: Instant) {
        self.add_seconds(phase, since.elapsed().as_secs_f64());
    }

    /// Adds one run of `phase` that took `seconds`.
    pub(crate) fn add_seconds(&mut self, phase: Phase, seconds: f64) {
        self.seconds[phase as usize] += seconds;
        self.runs[phase as usize] += 1;
    }

    /// Whether `phase` ran in the step.
    pub fn ran(&self, phase: Phase) -> bool {
        self.runs[phase as usize] > 0
    }

    /// How many times `phase` ran (the predictor–corrector searches neighbours twice with
    /// viscosity and det F).
    pub fn runs(&self, phase: Phase) -> u32 {
        self.runs[phase as usize]
    }

    /// Wall time spent in `phase`, in seconds.
    pub fn seconds(&self, phase: Phase) -> f64 {
        self.seconds[phase as usize]
    }

    /// The phases that ran, in step order.
    pub fn ran_phases(&self) -> impl Iterator<Item = Phase> + '_ {
        Phase::ALL.into_iter().filter(|p| self.ran(*p))
    }

    /// Sums `other` into `self` (totals over a run).
    pub fn accumulate(&mut self, other: &PhaseTimes) {
        for k in 0..Phase::ALL.len() {
            self.seconds[k] += other.seconds[k];
            self.runs[k] += other.runs[k];
        }
    }
}

/// Changes of the fluid's kinetic energy in one step, by cause (see [`StepReport::energy`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyBudget {
    /// `½ Σ m (|u*|² − |uⁿ|²)`: gravity and viscosity.
    pub explicit: f64,
    /// `½ Σ m (|u_proj|² − |u*|²)`: the pressure projection. An orthogonal projection
    /// (gradient the negative adjoint of the divergence, and the matching Laplacian) never
    /// makes it positive.
    pub projection: f64,
    /// `½ Σ m (|uⁿ⁺¹|² − |u_proj|²)`: shifting's velocity correction and the walls' guard.
    pub regularisation: f64,
}

/// What one time step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Step number (0-based).
    pub step: usize,
    /// Time at the end of the step.
    pub t: f64,
    /// Step size used.
    pub dt: f64,
    /// Pressure solve statistics.
    pub solve: SolveInfo,
    /// max |∇·uⁿ⁺¹| over non-free-surface fluid particles at the configuration the projection
    /// used (only when the `div_u` diagnostic is on).
    pub max_div_u: Option<f64>,
    /// det F of the step (only when the `det_f` diagnostic is on).
    pub det_f: Option<DetFStats>,
    /// Number of free-surface (Dirichlet) particles.
    pub free_surface_particles: usize,
    /// Particles whose renormalisation matrix was singular (identity used instead).
    pub correction_fallbacks: usize,
    /// Fluid rows where the quadratic-fit Hessian fell back to Eq. 25 (DG only; the wall rows
    /// have their own equation).
    pub hessian_fallbacks: usize,
    /// Multiplier of the mean-zero pressure gauge (closed domains; 0 otherwise): the
    /// right-hand-side part incompatible with a constant pressure null space.
    pub gauge_multiplier: f64,
    /// Fluid particles in wall material after the step (0 without walls).
    pub wall_penetrations: usize,
    /// Largest displacement of a fluid particle in the step, in smoothing lengths.
    pub max_displacement: f64,
    /// Fluid particles whose displacement would have crossed a wall and was cut short (the
    /// walls' guard; 0 when the wall condition held them).
    pub wall_guarded: usize,
    /// Free-surface particles in contact with a wall whose velocity into it the free-surface
    /// wall condition removed ([`Walls::hold_contacts`](crate::Walls::hold_contacts)), summed
    /// over the step's applications (to the projected velocity, and to the copy of `uⁿ` the
    /// predictor–corrector's displacement reads).
    pub wall_contacts: usize,
    /// The fluid's kinetic energy `½ Σ m |u|²` split by what changed it in this step: the
    /// explicit forces (`u* − uⁿ`: gravity, viscosity), the projection (`u_proj − u*`, with the
    /// free-surface particles' wall condition) and the
    /// particle regularisation (shifting's velocity correction and the walls' guard). Their sum
    /// is the step's change of kinetic energy.
    pub energy: EnergyBudget,
    /// Which passes ran and how long each took.
    pub phases: PhaseTimes,
    /// Wall time of the whole step in seconds.
    pub seconds: f64,
}
