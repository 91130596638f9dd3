//! # sph-integrators
//!
//! Time-update schemes of incompressible SPH behind one [`Integrator`] interface:
//!
//! | scheme | pressure equation | evaluated at | position update | paper |
//! |---|---|---|---|---|
//! | [`EulerIsph`] | PPE `∇·(∇p/ρ) = ∇·u*/Δt` | `xⁿ` | `xⁿ⁺¹ = xⁿ + Δt uⁿ⁺¹` | Eq. 3–4 |
//! | [`PredictorCorrectorIsph`] | PPE | `x' = xⁿ + Δt uⁿ` | `xⁿ⁺¹ = xⁿ + Δt (uⁿ + uⁿ⁺¹)/2` | Algorithm 2 |
//! | [`DgIsph`] | `(Δt²/ρ) cof(A):∇∇p = det A − 1` | `xⁿ` | `xⁿ⁺¹ = xⁿ + Δt uⁿ⁺¹` | Algorithm 1 |
//!
//! All three share one [`Simulation`] (particles, kernel, neighbour search, solver, scratch) and
//! one projection (the `projection` module): neighbours → renormalisation → free-surface flags →
//! assemble → solve (warm-started) → `uⁿ⁺¹ = u* − Δt ∇p/ρ`. So a comparison between schemes is
//! like for like. Every step returns a [`StepReport`] (solver statistics, max |∇·u|, det F
//! statistics) or a [`StepError`] naming what failed and where.
//!
//! Start with [`Simulation::new`] and [`Integrator::step`].

mod checkpoint;
mod config;
mod error;
mod frame;
mod projection;
mod relax;
mod report;
mod schemes;
mod simulation;
#[cfg(test)]
mod tests;
mod time_step;
mod wall_geometry;
mod walls;

pub use checkpoint::{Checkpoint, RestoreError};
pub use config::{
    DensityRelaxationForm, Diagnostics, Effects, FreeSurface, HYPERVISCOUS_STEP, Hyperviscosity,
    HyperviscousRegion, Limits, PeriodicAxes, ShiftScale, ShiftVelocity, Shifting, SimConfig,
    Viscosity, ViscousOperator,
};
pub use error::{COLLAPSE_FRACTION, StepError};
pub use frame::Frame;
pub use relax::{RELAX_COEFFICIENT, RelaxReport};
pub use report::{DetFStats, EnergyBudget, Phase, PhaseTimes, StepReport};
pub use schemes::{DgIsph, EulerIsph, Integrator, PredictorCorrectorIsph, Scheme, SchemeKind};
pub use simulation::Simulation;
pub use time_step::{AutoTimeStep, DtBound};
pub use wall_geometry::{WallBox, WallBoxKind, WallGeometry};
pub use walls::{Ghosts, WallCondition, WallError, WallModel, Walls};
