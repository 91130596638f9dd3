//! Section 3 of the paper: particles advected by a prescribed steady, divergence-free linear
//! field `u = G x` with the Euler and the predictor–corrector position updates; the volume is
//! lost (or gained) at the exact rate `ln det F / Δt` per unit time, with `F = I + ΔtG` (Euler)
//! and `F = I + ΔtG + Δt²G²/2` (predictor–corrector, i.e. Heun's method for a steady linear
//! field). Effects: none (no pressure, no neighbours).

use crate::measure::{hull_measure, second_moments};
use crate::reference::References;
use crate::{Check, Scene};
use sph_core::{Dim, MatrixOps, VectorOps};

/// Position-update rule of Section 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PositionUpdate {
    /// `x ← x + Δt u(x)` (paper Eq. 4).
    Euler,
    /// `x' = x + Δt u(x)`, `x ← x + Δt (u(x) + u(x'))/2` (paper Appendix A).
    PredictorCorrector,
}

impl PositionUpdate {
    /// Short name (`euler`, `pc`), as in the reference table.
    pub fn name(self) -> &'static str {
        match self {
            PositionUpdate::Euler => "euler",
            PositionUpdate::PredictorCorrector => "pc",
        }
    }

    /// The exact slope `ln det F / Δt` for `u = G x`.
    pub fn exact_slope<D: Dim>(self, g: &D::Matrix, dt: f64) -> f64 {
        let i = D::Matrix::IDENTITY;
        let f = match self {
            PositionUpdate::Euler => i + *g * dt,
            PositionUpdate::PredictorCorrector => i + *g * dt + (*g * *g) * (0.5 * dt * dt),
        };
        // det F − 1 from the invariants of F − I: no cancellation when det F ≈ 1 (the 2D
        // predictor–corrector has det F − 1 = Δt⁴ I2²/4 ≈ 6e-9).
        let inv = sph_operators::invariants::<D>(&(f - i));
        (inv.i1 + inv.i2 + inv.i3).ln_1p() / dt
    }
}

/// Result of one prescribed-field run.
#[derive(Clone, Debug, PartialEq)]
pub struct PrescribedRun {
    /// Update rule.
    pub update: PositionUpdate,
    /// Number of particles.
    pub particles: usize,
    /// Times `t_n` and the hull and second-moment measures `V_n`.
    pub series: Vec<(f64, f64, f64)>,
    /// Least-squares slope of `ln(V_n / V_0)` against `t_n`, hull measure.
    pub slope_hull: f64,
    /// The same from the second moments.
    pub slope_moments: f64,
    /// `ln det F / Δt`, computed from `G`.
    pub exact_slope: f64,
}

/// Least-squares slope of `y` against `x`.
pub fn fit_slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Advects `points` with `u = G x` for `steps` steps of `dt`.
pub fn run_prescribed<D: Dim>(
    mut points: Vec<D::Vector>,
    g: D::Matrix,
    dt: f64,
    steps: usize,
    update: PositionUpdate,
) -> PrescribedRun {
    let mut series = Vec::with_capacity(steps + 1);
    let measure = |p: &[D::Vector]| {
        (
            hull_measure::<D>(p).unwrap_or(f64::NAN),
            second_moments::<D>(p).measure,
        )
    };
    let (h0, m0) = measure(&points);
    series.push((0.0, h0, m0));
    for n in 1..=steps {
        for x in points.iter_mut() {
            let u = g * *x;
            *x = match update {
                PositionUpdate::Euler => *x + u * dt,
                PositionUpdate::PredictorCorrector => {
                    let xp = *x + u * dt;
                    *x + (u + g * xp) * (0.5 * dt)
                }
            };
        }
        let (h, m) = measure(&points);
        series.push((n as f64 * dt, h, m));
    }
    let t: Vec<f64> = series.iter().map(|s| s.0).collect();
    let lh: Vec<f64> = series.iter().map(|s| (s.1 / h0).ln()).collect();
    let lm: Vec<f64> = series.iter().map(|s| (s.2 / m0).ln()).collect();
    PrescribedRun {
        update,
        particles: points.len(),
        slope_hull: fit_slope(&t, &lh),
        slope_moments: fit_slope(&t, &lm),
        exact_slope: update.exact_slope::<D>(&g, dt),
        series,
    }
}

/// The paper's fields: 2D `u = (−100x, 100y)` (Eq. 14) on the ellipse `x² + y²/0.7² = 1`, 3D
/// `u = (100x, −50y, −50z)` (Eq. 15) on the spheroid `x² + (y² + z²)/0.7² = 1`.
pub fn paper_setup<D: Dim>() -> (D::Vector, D::Matrix) {
    let semi = D::Vector::from_fn(|k| if k == 0 { 1.0 } else { 0.7 });
    let g = if D::DIM == 2 {
        D::Matrix::from_fn(|i, j| {
            if i != j {
                0.0
            } else if i == 0 {
                -100.0
            } else {
                100.0
            }
        })
    } else {
        D::Matrix::from_fn(|i, j| {
            if i != j {
                0.0
            } else if i == 0 {
                100.0
            } else {
                -50.0
            }
        })
    };
    (semi, g)
}

/// Runs both updates for a prescribed-field scene and returns the runs and their checks
/// against the exact slopes (0.5 % tolerance, the bar) and the reference table.
pub fn run_scene<D: Dim>(scene: &Scene, refs: &References) -> (Vec<PrescribedRun>, Vec<Check>) {
    let (semi, g) = paper_setup::<D>();
    let steps = (scene.t_end / scene.dt + 1e-9).floor() as usize;
    let case = scene.case.name();
    let table_case = if D::DIM == 2 { "2d_sec3" } else { "3d_sec3" };
    let mut runs = Vec::new();
    let mut checks = Vec::new();
    for update in [PositionUpdate::Euler, PositionUpdate::PredictorCorrector] {
        let pts = crate::geometry::ellipsoid_lattice::<D>(semi, scene.dx);
        let run = run_prescribed::<D>(pts, g, scene.dt, steps, update);
        let tol = 0.005 * run.exact_slope.abs();
        let label = format!("{} {}D", update.name(), D::DIM);
        checks.push(Check::new(
            case,
            format!("{label} slope (hull)"),
            run.slope_hull,
            run.exact_slope,
            tol,
            "ln det F/Δt, exact",
        ));
        checks.push(Check::new(
            case,
            format!("{label} slope (2nd moments)"),
            run.slope_moments,
            run.exact_slope,
            tol,
            "ln det F/Δt, exact",
        ));
        if let Some(tab) = refs.volume_slope(table_case, update.name(), scene.dt) {
            checks.push(Check::new(
                case,
                format!("{label} exact slope vs table"),
                run.exact_slope,
                tab,
                1e-8 * tab.abs().max(1e-12),
                "volume_slopes.csv",
            ));
        }
        runs.push(run);
    }
    (runs, checks)
}
