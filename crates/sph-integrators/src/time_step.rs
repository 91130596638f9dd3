/// How the time step is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeStep {
    /// A fixed step (the paper's drops: Δt = 2e-4).
    Fixed(f64),
    /// `Δt = min(cfl · h / max|u|, visc · h² / ν, max)`, the CFL and viscous limits.
    Adaptive {
        /// CFL number (e.g. 0.25).
        cfl: f64,
        /// Viscous number (e.g. 0.125).
        visc: f64,
        /// Kinematic viscosity ν (0 for inviscid).
        nu: f64,
        /// Upper bound on Δt.
        max: f64,
    },
}

impl TimeStep {
    /// The step for smoothing length `h` and maximum speed `u_max`.
    pub fn dt(&self, h: f64, u_max: f64) -> f64 {
        match *self {
            TimeStep::Fixed(dt) => dt,
            TimeStep::Adaptive { cfl, visc, nu, max } => {
                let mut dt = max;
                if u_max > 0.0 {
                    dt = dt.min(cfl * h / u_max);
                }
                if nu > 0.0 {
                    dt = dt.min(visc * h * h / nu);
                }
                dt
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adaptive_takes_the_smallest_limit() {
        let ts = TimeStep::Adaptive {
            cfl: 0.25,
            visc: 0.125,
            nu: 0.01,
            max: 1.0,
        };
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b;
        // CFL: 0.25 · 0.1 / 10 = 2.5e-3 < viscous 0.125 · 0.1² / 0.01 = 0.125.
        assert!(close(ts.dt(0.1, 10.0), 2.5e-3));
        // At rest only the viscous limit applies.
        assert!(close(ts.dt(0.1, 0.0), 0.125));
        assert_eq!(TimeStep::Fixed(2e-4).dt(0.1, 1e9), 2e-4);
    }
}
