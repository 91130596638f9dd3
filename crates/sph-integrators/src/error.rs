use crate::time_step::DtBound;
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
        "step {step} (t = {t:.6e}): blow-up: particle {particle} would move {value:.3e} smoothing lengths in one step (limit {limit:e}); {}",
        blow_up_cause(*advective_number, *viscous_number, *dt_bound)
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
        /// The limit that set the step's `Δt`, when it was chosen automatically (set by the run
        /// loop, which chose it; `None` from a step).
        dt_bound: Option<DtBound>,
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
    /// The fluid needs more mirror ghosts than the walls have slots
    /// ([`Ghosts`](crate::Ghosts)): more particles have gathered within a support of the walls
    /// than the builder allowed for. The particles are left as they were before the step.
    #[error(
        "step {step} (t = {t:.6e}): the fluid needs {needed} mirror ghosts, the walls have {slots} slots (particles have gathered at the walls)"
    )]
    GhostCapacity {
        /// Step number.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// Ghosts the positions need.
        needed: usize,
        /// Slots the walls have.
        slots: usize,
    },
    /// The time step is not a positive finite number.
    #[error("step {step}: invalid time step {dt}")]
    InvalidTimeStep {
        /// Step number.
        step: usize,
        /// The offending value.
        dt: f64,
    },
    /// The largest fluid speed passed `limit` times the flow's velocity scale (set by the run
    /// loop, which knows the scale): the flow has run away. With automatic steps no single step
    /// need move a particle far, so the displacement check ([`StepError::BlowUp`]) would not
    /// catch it.
    #[error(
        "step {step} (t = {t:.6e}): blow-up: fluid particle {particle} moves at {speed:.3e}, more than {limit} times the flow's velocity scale {scale:.3e} (`[limits] max_speed_ratio`)"
    )]
    SpeedRunaway {
        /// Step number.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// The fastest fluid particle, by its index in the initial state.
        particle: usize,
        /// Its speed.
        speed: f64,
        /// The flow's velocity scale.
        scale: f64,
        /// The limit, as a multiple of the scale.
        limit: f64,
    },
    /// The automatic time step fell below [`COLLAPSE_FRACTION`] of the largest step so far: the
    /// flow is running away (its speed, and with it the advective limit, without bound), which a
    /// shrinking step would otherwise follow for ever without any one step moving a particle far.
    #[error(
        "step {step} (t = {t:.6e}): blow-up: the automatic time step fell to {dt:.3e}, below {COLLAPSE_FRACTION:e} of the run's largest step {largest:.3e} ({} binds: the largest speed is {speed:.3e})",
        bound.name()
    )]
    TimeStepCollapse {
        /// Step number.
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// The step the limits allow.
        dt: f64,
        /// The largest step taken so far.
        largest: f64,
        /// The largest fluid speed at the step's start.
        speed: f64,
        /// The limit that set it.
        bound: DtBound,
    },
}

/// The smallest automatic time step, as a fraction of the run's largest, before the run is
/// stopped as a blow-up ([`StepError::TimeStepCollapse`]). A dam break's steps shrink about
/// twentyfold from rest to its front's speed; a blow-up's by many orders of magnitude.
pub const COLLAPSE_FRACTION: f64 = 1e-3;

impl StepError {
    /// The error with a particle slot it names replaced by `ids[slot]`, the particle's index in
    /// the initial state (see [`Simulation::ids`](crate::Simulation::ids)).
    pub(crate) fn with_particle_ids(mut self, ids: &[u32]) -> Self {
        match &mut self {
            StepError::NonFinite { particle, .. }
            | StepError::BlowUp { particle, .. }
            | StepError::SpeedRunaway { particle, .. }
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

/// The blow-up message's cause: with a fixed step, "the time step is too large … or the flow
/// is unstable" with the step's numbers; with an automatic one, which limit set the step
/// (then the step was within every limit: the flow is unstable).
fn blow_up_cause(advective: f64, viscous: f64, bound: Option<DtBound>) -> String {
    let numbers = blow_up_numbers(advective, viscous);
    match bound {
        None => {
            format!("the time step is too large for this flow ({numbers}), or the flow is unstable")
        }
        Some(b) => format!(
            "the automatic time step was set by {} and kept every limit ({numbers}): the flow is \
             unstable at this resolution, or the limits' coefficients (`[time_step]`) are too large \
             for it",
            b.name()
        ),
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
