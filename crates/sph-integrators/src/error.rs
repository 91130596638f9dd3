use sph_neighbors::NeighborError;
use sph_pressure::{PressureError, SolveError};
use thiserror::Error;

/// Why a time step failed. Every variant names the step and time.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum StepError {
    /// Neighbour search refused the particle positions.
    #[error("step {step} (t = {t:.6e}): neighbour search failed: {source}")]
    Neighbors {
        /// Step number (0-based) that failed.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// Cause.
        source: NeighborError,
    },
    /// Pressure-equation assembly failed.
    #[error("step {step} (t = {t:.6e}): pressure assembly failed: {source}")]
    Assembly {
        /// Step number.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// Cause.
        source: PressureError,
    },
    /// The pressure solve failed (no convergence, breakdown, singular pivot).
    #[error("step {step} (t = {t:.6e}): pressure solve failed: {source}")]
    Solve {
        /// Step number.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// Cause.
        source: SolveError,
    },
    /// A particle field became NaN or infinite.
    #[error("step {step} (t = {t:.6e}): {field} of particle {particle} is not finite")]
    NonFinite {
        /// Step number.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// Field name.
        field: &'static str,
        /// First offending particle.
        particle: usize,
    },
    /// The time step is not a positive finite number.
    #[error("step {step}: invalid time step {dt}")]
    InvalidTimeStep {
        /// Step number.
        step: usize,
        /// The offending value.
        dt: f64,
    },
}
