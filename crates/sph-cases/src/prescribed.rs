//! Section 3 of the paper: particles advected by a prescribed steady, divergence-free linear
//! field `u = G x` with the Euler and the predictor–corrector position updates; the volume is
//! lost (or gained) at the exact rate `ln det F / Δt` per unit time, with `F = I + ΔtG` (Euler)
//! and `F = I + ΔtG + Δt²G²/2` (predictor–corrector, i.e. Heun's method for a steady linear
//! field). Effects: none (no pressure, no neighbours): the case advances its particles itself
//! ([`Case::advance`]), with the scheme naming the position update.

use crate::case::{Case, Column, Finish, Results, Setup};
use crate::measure::{hull_measure, second_moments};
use crate::reference::References;
use crate::{CaseError, Check, Scene};
use sph_core::{Dim, MatrixOps, ParticleSet, VectorOps};
use sph_integrators::{Scheme, SchemeKind, Simulation, StepError, StepReport};

/// Position-update rule of Section 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PositionUpdate {
    /// `x ← x + Δt u(x)` (paper Eq. 4).
    Euler,
    /// `x' = x + Δt u(x)`, `x ← x + Δt (u(x) + u(x'))/2` (paper Appendix A).
    PredictorCorrector,
}

impl PositionUpdate {
    /// The update of a scheme: Euler's for Euler and DG, Heun's for the predictor–corrector.
    pub fn of(scheme: SchemeKind) -> Self {
        match scheme {
            SchemeKind::PredictorCorrector => PositionUpdate::PredictorCorrector,
            _ => PositionUpdate::Euler,
        }
    }

    /// Short name, as in the reference table (`euler`, `pc`).
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

    /// One step of `x` under `u = G x`.
    #[inline]
    pub fn advect<D: Dim>(self, x: D::Vector, g: D::Matrix, dt: f64) -> D::Vector {
        let u = g * x;
        match self {
            PositionUpdate::Euler => x + u * dt,
            PositionUpdate::PredictorCorrector => {
                let xp = x + u * dt;
                x + (u + g * xp) * (0.5 * dt)
            }
        }
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

fn measure<D: Dim>(p: &[D::Vector]) -> (f64, f64) {
    (
        hull_measure::<D>(p).unwrap_or(f64::NAN),
        second_moments::<D>(p).measure,
    )
}

fn slopes(series: &[(f64, f64, f64)]) -> (f64, f64) {
    let (h0, m0) = (series[0].1, series[0].2);
    let t: Vec<f64> = series.iter().map(|s| s.0).collect();
    let lh: Vec<f64> = series.iter().map(|s| (s.1 / h0).ln()).collect();
    let lm: Vec<f64> = series.iter().map(|s| (s.2 / m0).ln()).collect();
    (fit_slope(&t, &lh), fit_slope(&t, &lm))
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
    let (h0, m0) = measure::<D>(&points);
    series.push((0.0, h0, m0));
    for n in 1..=steps {
        for x in points.iter_mut() {
            *x = update.advect::<D>(*x, g, dt);
        }
        let (h, m) = measure::<D>(&points);
        series.push((n as f64 * dt, h, m));
    }
    let (slope_hull, slope_moments) = slopes(&series);
    PrescribedRun {
        update,
        particles: points.len(),
        slope_hull,
        slope_moments,
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

/// The Section 3 case: the scene's schemes name the position update (Euler, or the
/// predictor–corrector's Heun update).
pub struct PrescribedCase<D: Dim> {
    scene: Scene,
    update: PositionUpdate,
    g: D::Matrix,
    table_slope: Option<f64>,
    series: Vec<(f64, f64, f64)>,
}

impl<D: Dim> PrescribedCase<D> {
    /// The case of `scene` run with `scheme`'s position update.
    pub fn new(scene: &Scene, scheme: SchemeKind, refs: &References) -> Self {
        let update = PositionUpdate::of(scheme);
        let table_case = if D::DIM == 2 { "2d_sec3" } else { "3d_sec3" };
        Self {
            scene: scene.clone(),
            update,
            g: paper_setup::<D>().1,
            table_slope: refs.volume_slope(table_case, update.name(), scene.dt),
            series: Vec::new(),
        }
    }
}

impl<D: Dim> Case<D> for PrescribedCase<D> {
    crate::case::state_fields!(series);

    fn setup(&self) -> Result<Setup<D>, CaseError> {
        let (semi, _) = paper_setup::<D>();
        let pts = crate::geometry::ellipsoid_lattice::<D>(semi, self.scene.dx);
        let mut particles =
            ParticleSet::<D>::from_positions(pts, self.scene.dx.powi(D::DIM as i32), 1.0);
        for (u, x) in particles.velocities.iter_mut().zip(&particles.positions) {
            *u = self.g * *x;
        }
        Ok(Setup {
            particles,
            config: self.scene.sim_config(),
            walls: None,
            carved: 0,
        })
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column::new("measure_hull", "volume", "convex-hull area/volume"),
            Column::new("measure_moments", "volume", "second-moment area/volume"),
        ]
    }

    fn sample_every(&self, _steps: usize) -> usize {
        1
    }

    fn frame_every(&self) -> usize {
        1
    }

    fn advance(
        &mut self,
        sim: &mut Simulation<D>,
        _scheme: &mut Scheme,
        dt: f64,
    ) -> Result<StepReport, StepError> {
        let (g, update) = (self.g, self.update);
        let p = &mut sim.particles;
        for (x, u) in p.positions.iter_mut().zip(p.velocities.iter_mut()) {
            *x = update.advect::<D>(*x, g, dt);
            *u = g * *x;
        }
        if let Some(particle) = p.positions.iter().position(|x| !x.is_finite()) {
            return Err(StepError::NonFinite {
                step: sim.step,
                t: sim.t,
                field: "position",
                particle,
            });
        }
        let report = StepReport {
            step: sim.step,
            t: sim.t + dt,
            dt,
            ..StepReport::default()
        };
        sim.t += dt;
        sim.step += 1;
        Ok(report)
    }

    fn observe(
        &mut self,
        sim: &Simulation<D>,
        _report: Option<&StepReport>,
        _short: bool,
        out: &mut Vec<f64>,
    ) -> Result<(), CaseError> {
        let (h, m) = measure::<D>(&sim.particles.positions);
        // The step's time as n Δt (not the running sum), as the exact slope is per Δt.
        self.series.push((sim.step as f64 * self.scene.dt, h, m));
        out.extend_from_slice(&[h, m]);
        Ok(())
    }

    fn finish(&mut self, _sim: &Simulation<D>) -> Result<Finish, CaseError> {
        let mut results = Results::new();
        if self.series.len() >= 2 {
            let (hull, moments) = slopes(&self.series);
            results.insert("slope_hull".into(), hull);
            results.insert("slope_moments".into(), moments);
        }
        results.insert(
            "exact_slope".into(),
            self.update.exact_slope::<D>(&self.g, self.scene.dt),
        );
        if let Some(s) = self.table_slope {
            results.insert("table_slope".into(), s);
        }
        Ok(Finish {
            tables: Vec::new(),
            results,
        })
    }

    fn checks(&self, scheme: SchemeKind, _label: &str, r: &Results) -> Vec<Check> {
        let get = |k: &str| r.get(k).copied().unwrap_or(f64::NAN);
        let case = self.scene.case.name();
        let exact = get("exact_slope");
        let tol = 0.005 * exact.abs();
        let label = format!("{} {}D", scheme.name(), D::DIM);
        let mut out = vec![
            Check::new(
                case,
                format!("{label} slope (hull)"),
                get("slope_hull"),
                exact,
                tol,
                "ln det F/Δt, exact",
            ),
            Check::new(
                case,
                format!("{label} slope (2nd moments)"),
                get("slope_moments"),
                exact,
                tol,
                "ln det F/Δt, exact",
            ),
        ];
        if let Some(tab) = self.table_slope {
            out.push(Check::new(
                case,
                format!("{label} exact slope vs table"),
                exact,
                tab,
                1e-8 * tab.abs().max(1e-12),
                "volume_slopes.csv",
            ));
        }
        out
    }
}
