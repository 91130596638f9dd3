//! Any flow a scene poses with its `[[fluid]]`, `[[wall]]` and `[domain]` blocks: the case
//! behind `case = "flow"` (the default).
//!
//! Effects: exactly those the scene declares — `[effects]` (gravity, viscosity, shifting),
//! `[free_surface]`, the walls of its `[[wall]]` blocks, periodic axes of its `[domain]`.
//! Records, besides the common columns: the fluid's centroid and pressure range. Checks: the
//! scene's `[[check]]` tables, on the run loop's results (`max_wall_penetrations`,
//! `reached_t`, `max_speed`, ...) and this case's (`centroid_*`).

use crate::case::{Case, Column, Finish, Results, Setup};
use crate::{CaseError, Scene};
use sph_core::{Dim, VectorOps};
use sph_integrators::{Simulation, StepReport, WallCondition};

/// The initial state of a scene's blocks (the scene must be a valid `flow` or `dam_break`
/// scene of dimension `D::DIM`).
pub fn setup<D: Dim>(scene: &Scene) -> Result<Setup<D>, CaseError> {
    let condition = scene.wall_condition.unwrap_or(WallCondition::Continuation);
    let built = crate::geometry::build_blocks::<D>(scene, &scene.fluid, &scene.wall, condition)?;
    let fluid = built
        .walls
        .as_ref()
        .map_or(built.particles.len(), |w| w.first);
    if fluid < MIN_FLUID {
        return Err(CaseError::Invalid {
            scene: scene.case.name().into(),
            field: "dx".into(),
            message: format!(
                "= {} leaves {fluid} fluid particles in the [[fluid]] blocks; a flow needs at \
                 least {MIN_FLUID}",
                scene.dx
            ),
        });
    }
    Ok(Setup {
        particles: built.particles,
        config: scene.sim_config(),
        walls: built.walls,
        carved: built.carved,
    })
}

/// Fewest fluid particles a block-posed scene may have (a few kernel supports' worth).
pub const MIN_FLUID: usize = 16;

/// The fluid's centroid.
pub fn centroid<D: Dim>(sim: &Simulation<D>) -> D::Vector {
    let nf = sim.fluid_len();
    sim.particles.positions[..nf]
        .iter()
        .copied()
        .sum::<D::Vector>()
        * (1.0 / nf.max(1) as f64)
}

/// The generic flow case.
pub struct FlowCase {
    scene: Scene,
    centroid: [f64; 3],
}

impl FlowCase {
    /// The flow of `scene`.
    pub fn new(scene: &Scene) -> Self {
        Self {
            scene: scene.clone(),
            centroid: [f64::NAN; 3],
        }
    }
}

impl<D: Dim> Case<D> for FlowCase {
    fn setup(&self) -> Result<Setup<D>, CaseError> {
        setup::<D>(&self.scene)
    }

    fn columns(&self) -> Vec<Column> {
        vec![
            Column::new("centroid_x", "length", "x of the fluid's centroid"),
            Column::new("centroid_y", "length", "y of the fluid's centroid"),
            Column::new(
                "centroid_z",
                "length",
                "z of the fluid's centroid (0 in 2D)",
            ),
            Column::new("pressure_min", "pressure", "lowest fluid pressure"),
            Column::new("pressure_max", "pressure", "highest fluid pressure"),
        ]
    }

    fn observe(
        &mut self,
        sim: &Simulation<D>,
        _report: Option<&StepReport>,
        _short: bool,
        out: &mut Vec<f64>,
    ) -> Result<(), CaseError> {
        let c = centroid(sim).to_array3();
        self.centroid = c;
        let pf = &sim.particles.pressures[..sim.fluid_len()];
        let (lo, hi) = pf
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(*p), b.max(*p))
            });
        out.extend_from_slice(&[c[0], c[1], c[2], lo, hi]);
        Ok(())
    }

    fn finish(&mut self, _sim: &Simulation<D>) -> Result<Finish, CaseError> {
        let mut results = Results::new();
        for (k, name) in ["centroid_x", "centroid_y", "centroid_z"]
            .iter()
            .enumerate()
        {
            results.insert((*name).into(), self.centroid[k]);
        }
        Ok(Finish {
            tables: Vec::new(),
            results,
        })
    }
}
