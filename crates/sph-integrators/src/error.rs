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
    /// A particle moved further in one step than the limit allows
    /// ([`Limits::max_displacement`](crate::Limits)): the flow has blown up (or the step is far
    /// too large for it). The particles are left as they were before the step. The message
    /// gives the step's viscous number `ν Δt / h²`: the viscous term is explicit, and a scene
    /// refined at a fixed Courant number crosses the viscous limit (`ν Δt / h² ≤ 0.125` advised
    /// by Morris, Fox & Zhu 1997) as `dx` shrinks. The Re 100 cavity runs at 0.15 (100²) and
    /// 0.30 (500², `Δt = 1e-4`), and blew up in its second step at 0.74 (500², `Δt = dx/4`).
    #[error(
        "step {step} (t = {t:.6e}): blow-up: particle {particle} would move {value:.3e} smoothing lengths in one step (limit {limit:e}); the time step is too large for this flow ({}), or the flow is unstable",
        blow_up_numbers(*advective_number, *viscous_number)
    )]
    BlowUp {
        /// Step number.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// The particle that moved furthest.
        particle: usize,
        /// Its displacement in smoothing lengths.
        value: f64,
        /// The limit in smoothing lengths.
        limit: f64,
        /// The step's viscous number `ν Δt / h²` (0 without viscosity).
        viscous_number: f64,
        /// The step's advective number `max |u| Δt / h` at its start.
        advective_number: f64,
    },
    /// A fluid particle would end deeper in wall material than the walls are thick: it has passed
    /// through a wall. The particles are left as they were before the step.
    #[error(
        "step {step} (t = {t:.6e}): fluid particle {particle} would end {depth:.3e} deep in a wall, past its {thickness:.3e} thick wall layers (it has passed through the wall)"
    )]
    Escaped {
        /// Step number.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// The deepest particle.
        particle: usize,
        /// How deep it would lie.
        depth: f64,
        /// The walls' thickness.
        thickness: f64,
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

impl StepError {
    /// The error with a particle slot it names replaced by `ids[slot]`, the particle's index in
    /// the initial state (see [`Simulation::ids`](crate::Simulation::ids)).
    pub(crate) fn with_particle_ids(mut self, ids: &[u32]) -> Self {
        match &mut self {
            StepError::NonFinite { particle, .. }
            | StepError::BlowUp { particle, .. }
            | StepError::Escaped { particle, .. } => {
                if let Some(&id) = ids.get(*particle) {
                    *particle = id as usize;
                }
            }
            _ => {}
        }
        self
    }
}

/// The blow-up message's numbers: the advective number `max |u| Δt / h` always, the viscous
/// number `ν Δt / h²` only for a viscous flow.
fn blow_up_numbers(advective: f64, viscous: f64) -> String {
    // Three decimals, or two significant digits for what would print as 0.000.
    let num = |v: f64| {
        if v == 0.0 || v >= 1e-3 {
            format!("{v:.3}")
        } else {
            format!("{v:.1e}")
        }
    };
    let mut s = format!(
        "at the step's start its advective number max |u| Δt / h was {}; about 0.25 or less is \
         usual",
        num(advective)
    );
    if viscous > 0.0 {
        s.push_str(&format!(
            "; its viscous number ν Δt / h² is {}; Morris et al. 1997 advise at most 0.125 for \
             the explicit viscous term",
            num(viscous)
        ));
    }
    s
}
