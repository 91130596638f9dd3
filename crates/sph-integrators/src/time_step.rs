//! The automatic time step: the largest step the explicit parts of a step allow.

use serde::{Deserialize, Serialize};

/// Which limit set a step's `Δt` ([`AutoTimeStep::choose`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DtBound {
    /// The scene's `dt` (the upper bound).
    Scene,
    /// Advection: `C_u h / max|u|`.
    Advective,
    /// Explicit viscosity: `C_ν h² / ν`.
    Viscous,
    /// Body force: `C_f √(h / |g|)`.
    Force,
}

impl DtBound {
    /// The limit's name in messages and records.
    pub fn name(self) -> &'static str {
        match self {
            DtBound::Scene => "the scene's dt",
            DtBound::Advective => "the advective limit",
            DtBound::Viscous => "the viscous limit",
            DtBound::Force => "the body-force limit",
        }
    }

    /// A number for a record's column: 0 scene, 1 advective, 2 viscous, 3 body force.
    pub fn code(self) -> f64 {
        match self {
            DtBound::Scene => 0.0,
            DtBound::Advective => 1.0,
            DtBound::Viscous => 2.0,
            DtBound::Force => 3.0,
        }
    }
}

/// Coefficients of the automatic time step
///
/// ```text
/// Δt = min(Δt_max, C_u h / max|u|, C_ν h² / ν, C_f √(h / |g|))
/// ```
///
/// the advective (CFL) limit, the explicit viscous limit of Morris, Fox & Zhu (1997, Eq. 26:
/// `0.125 h²/ν`) and the body-force limit of Monaghan (1992, `0.25 √(h/|f|)`). The projection
/// has no sound speed, so no acoustic limit applies. `Δt_max` is the scene's `dt`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutoTimeStep {
    /// `C_u`.
    pub advective: f64,
    /// `C_ν`.
    pub viscous: f64,
    /// `C_f`.
    pub force: f64,
}

impl Default for AutoTimeStep {
    fn default() -> Self {
        Self {
            advective: 0.2,
            viscous: 0.125,
            force: 0.25,
        }
    }
}

impl AutoTimeStep {
    /// The step for smoothing length `h`, largest fluid speed `u_max`, kinematic viscosity
    /// `nu` (0: inviscid) and body-force magnitude `g` (0: none), at most `dt_max`, and the
    /// limit that set it (the first in the order scene, advective, viscous, force on a tie).
    /// A pure function of its arguments: the same state gives the same bits.
    pub fn choose(&self, dt_max: f64, h: f64, u_max: f64, nu: f64, g: f64) -> (f64, DtBound) {
        let mut best = (dt_max, DtBound::Scene);
        let mut take = |dt: f64, bound: DtBound| {
            if dt < best.0 {
                best = (dt, bound);
            }
        };
        if u_max > 0.0 {
            take(self.advective * h / u_max, DtBound::Advective);
        }
        if nu > 0.0 {
            take(self.viscous * h * h / nu, DtBound::Viscous);
        }
        if g > 0.0 {
            take(self.force * (h / g).sqrt(), DtBound::Force);
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smallest_limit_sets_the_step() {
        let ts = AutoTimeStep {
            advective: 0.25,
            viscous: 0.125,
            force: 0.25,
        };
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b;
        // Advective: 0.25 · 0.1 / 10 = 2.5e-3 < viscous 0.125 · 0.1² / 0.01 = 0.125 and
        // force 0.25 √(0.1 / 9.81) = 0.0252.
        let (dt, b) = ts.choose(1.0, 0.1, 10.0, 0.01, 9.81);
        assert!(close(dt, 2.5e-3) && b == DtBound::Advective, "{dt} {b:?}");
        // At rest without gravity: the viscous limit.
        let (dt, b) = ts.choose(1.0, 0.1, 0.0, 0.01, 0.0);
        assert!(close(dt, 0.125) && b == DtBound::Viscous);
        // At rest under gravity, inviscid: the body-force limit.
        let (dt, b) = ts.choose(1.0, 0.1, 0.0, 0.0, 9.81);
        assert!(close(dt, 0.25 * (0.1f64 / 9.81).sqrt()) && b == DtBound::Force);
        // The scene's dt bounds them all.
        assert_eq!(
            ts.choose(1e-3, 0.1, 10.0, 0.01, 9.81),
            (1e-3, DtBound::Scene)
        );
        // Nothing moves and nothing acts: the scene's dt.
        assert_eq!(ts.choose(2e-4, 0.1, 0.0, 0.0, 0.0), (2e-4, DtBound::Scene));
    }
}
