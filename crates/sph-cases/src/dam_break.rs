//! A collapsing water column against the experiment of Martin & Moyce (1952): the case behind
//! `case = "dam_break"`.
//!
//! Geometry, effects and operators come from the scene's blocks, as for [`flow`](crate::flow):
//! the first `[[fluid]]` block is the column (a box of width `a` standing on the floor against
//! the back wall at its lower `x`), gravity points along `−y`. Records, besides the flow's
//! columns: the surge front `z` (the leading edge of the fluid body, measured from the back wall)
//! in the experiment's units `Z = z/a`, `T = t √(2g/a)`, and Martin & Moyce's `Z` at that `T`
//! (`cases/reference/dam_break_martin_moyce.csv`, n² = 2). The front is the largest `x` of a
//! fluid particle with at least three fluid neighbours (spray thrown ahead of the body does not
//! count), plus half a spacing (a particle's extent), so `Z = 1` at `T = 0`.
//!
//! Results: `front_error_max` and `front_error_rms` (relative, `|Z − Z_MM| / Z_MM`) over the
//! records with `2.5 ≤ T ≤ 6` taken while the front is more than a column width from the far
//! wall; `front_error_early_max` over `1.5 ≤ T < 2.5`, where the experiment's gate and the air
//! slow the real front (reported, not part of the comparison window); `t_impact`, when the front first comes within half a spacing of the far wall (NaN if
//! it does not). Checks: the scene's `[[check]]` tables.

use crate::case::{Case, Column, Finish, Setup};
use crate::flow::FlowCase;
use crate::reference::References;
use crate::{CaseError, Scene};
use sph_core::{Dim, VectorOps};
use sph_integrators::{Scheme, Simulation, StepError, StepReport};

/// Window of `T` over which the front is compared with the experiment.
pub const T_WINDOW: (f64, f64) = (2.5, 6.0);

/// The early part of the surge, `1.5 ≤ T < 2.5`, reported on its own: single-phase
/// simulations of this experiment lead it there (the gate is not lifted at once in the
/// experiment, and the air slows the front; `cases/reference/README.md`).
pub const T_EARLY: (f64, f64) = (1.5, 2.5);

/// The dam-break case (see the module docs).
pub struct DamBreakCase {
    flow: FlowCase,
    dx: f64,
    /// Back wall `x`, column width `a`, `√(2g/a)`.
    x0: f64,
    a: f64,
    time_scale: f64,
    /// `x` of the far wall the surge runs towards.
    far_wall: f64,
    refs: References,
    /// `(T, relative error)` in the comparison window.
    errors: Vec<(f64, f64)>,
    /// Largest `|error|` in the early window.
    early_max: f64,
    t_impact: f64,
}

/// The column's `x0`, `a`, `g` and the far wall's `x` of a dam-break scene, or what is wrong.
pub fn geometry(scene: &Scene) -> Result<(f64, f64, f64, f64), String> {
    let col = scene
        .fluid
        .first()
        .filter(|b| b.shape == crate::blocks::FluidShape::Box)
        .ok_or("the first [[fluid]] block must be the column, a box")?;
    let (lo, hi) = (
        col.min.clone().unwrap_or_default(),
        col.max.clone().unwrap_or_default(),
    );
    let g = scene.effects.gravity.ok_or("needs [effects] gravity")?;
    if g[0] != 0.0 || g[2] != 0.0 || g[1] >= 0.0 {
        return Err("gravity must point along −y: [0, −g, 0]".into());
    }
    let tank = scene
        .wall
        .iter()
        .find(|w| {
            w.kind == crate::blocks::WallKind::Container && w.min[0] <= lo[0] && w.max[0] > hi[0]
        })
        .ok_or("needs a container [[wall]] holding the column, longer than it along x")?;
    Ok((lo[0], hi[0] - lo[0], -g[1], tank.max[0]))
}

impl DamBreakCase {
    /// The dam break of `scene` (validated).
    pub fn new(scene: &Scene, refs: &References) -> Self {
        let (x0, a, g, far_wall) = geometry(scene).unwrap_or((0.0, 1.0, 9.81, f64::INFINITY));
        Self {
            flow: FlowCase::new(scene),
            dx: scene.dx,
            x0,
            a,
            time_scale: (2.0 * g / a).sqrt(),
            far_wall,
            refs: refs.clone(),
            errors: Vec::new(),
            early_max: f64::NAN,
            t_impact: f64::NAN,
        }
    }

    /// The leading edge of the fluid body: the largest `x` of a fluid particle with at least
    /// three fluid neighbours in the last projection's lists, plus `dx/2`.
    fn front<D: Dim>(&self, sim: &Simulation<D>) -> f64 {
        let nf = sim.fluid_len();
        let x = &sim.particles.positions;
        let lists = sim.neighbors();
        let body = |i: usize| {
            lists.len() != x.len()
                || lists
                    .row(i)
                    .iter()
                    .filter(|&&j| (j as usize) < nf && j as usize != i)
                    .count()
                    >= 3
        };
        (0..nf)
            .filter(|&i| body(i))
            .map(|i| x[i].get(0))
            .fold(f64::NEG_INFINITY, f64::max)
            + 0.5 * self.dx
    }
}

impl<D: Dim> Case<D> for DamBreakCase {
    fn save_state(&self) -> Vec<u8> {
        let mut w = crate::case::StateWriter::default();
        w.put("flow", &Case::<D>::save_state(&self.flow));
        w.put("errors", &self.errors);
        w.put("early_max", &self.early_max);
        w.put("t_impact", &self.t_impact);
        w.finish()
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), CaseError> {
        let r = crate::case::StateReader::new(bytes)?;
        Case::<D>::restore_state(&mut self.flow, &r.get::<Vec<u8>>("flow")?)?;
        self.errors = r.get("errors")?;
        self.early_max = r.get("early_max")?;
        self.t_impact = r.get("t_impact")?;
        Ok(())
    }

    fn setup(&self) -> Result<Setup<D>, CaseError> {
        Case::<D>::setup(&self.flow)
    }

    fn columns(&self) -> Vec<Column> {
        let mut c = Case::<D>::columns(&self.flow);
        c.extend([
            Column::new(
                "front",
                "length",
                "leading edge of the fluid body from the back wall",
            ),
            Column::new("time_T", "", "T = t √(2g/a)"),
            Column::new("front_Z", "", "Z = front / a"),
            Column::new("front_Z_reference", "", "Martin & Moyce (1952) Z at T"),
            Column::new("front_error", "", "(Z − Z_MM) / Z_MM"),
        ]);
        c
    }

    fn start(&mut self, sim: &Simulation<D>) -> Result<(), CaseError> {
        Case::<D>::start(&mut self.flow, sim)
    }

    fn advance(
        &mut self,
        sim: &mut Simulation<D>,
        scheme: &mut Scheme,
        dt: f64,
    ) -> Result<StepReport, StepError> {
        Case::<D>::advance(&mut self.flow, sim, scheme, dt)
    }

    fn observe(
        &mut self,
        sim: &Simulation<D>,
        report: Option<&StepReport>,
        short: bool,
        out: &mut Vec<f64>,
    ) -> Result<(), CaseError> {
        Case::<D>::observe(&mut self.flow, sim, report, short, out)?;
        let front = self.front(sim) - self.x0;
        let t_big = sim.t * self.time_scale;
        let z = front / self.a;
        let z_ref = self.refs.dam_break_front_at(t_big).unwrap_or(f64::NAN);
        let error = z / z_ref - 1.0;
        if self.t_impact.is_nan() && self.x0 + front >= self.far_wall - 0.5 * self.dx {
            self.t_impact = sim.t;
        }
        let free_run = self.x0 + front < self.far_wall - self.a;
        if (T_WINDOW.0..=T_WINDOW.1).contains(&t_big) && free_run && error.is_finite() {
            self.errors.push((t_big, error));
        }
        if (T_EARLY.0..T_EARLY.1).contains(&t_big) && free_run && error.is_finite() {
            self.early_max = self.early_max.max(error.abs());
        }
        out.extend_from_slice(&[front, t_big, z, z_ref, error]);
        Ok(())
    }

    fn finish(&mut self, sim: &Simulation<D>) -> Result<Finish, CaseError> {
        let mut f = Case::<D>::finish(&mut self.flow, sim)?;
        let n = self.errors.len();
        let (max, rms) = if n == 0 {
            (f64::NAN, f64::NAN)
        } else {
            (
                self.errors.iter().map(|e| e.1.abs()).fold(0.0, f64::max),
                (self.errors.iter().map(|e| e.1 * e.1).sum::<f64>() / n as f64).sqrt(),
            )
        };
        f.results.insert("front_error_max".into(), max);
        f.results.insert("front_error_rms".into(), rms);
        f.results
            .insert("front_error_early_max".into(), self.early_max);
        f.results.insert("front_points".into(), n as f64);
        f.results.insert("t_impact".into(), self.t_impact);
        f.results
            .insert("T_impact".into(), self.t_impact * self.time_scale);
        Ok(f)
    }
}

/// The results a dam break reports besides the flow's and the run loop's.
pub const RESULTS: [&str; 6] = [
    "front_error_max",
    "front_error_rms",
    "front_error_early_max",
    "front_points",
    "t_impact",
    "T_impact",
];

/// Checks a dam-break scene beyond [`Scene::validate`].
pub fn validate(scene: &Scene, name: &str) -> Result<(), CaseError> {
    geometry(scene)
        .map(|_| ())
        .map_err(|message| CaseError::Invalid {
            scene: name.to_string(),
            field: "fluid".into(),
            message,
        })
}
