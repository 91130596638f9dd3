//! Any flow a scene poses with its `[[fluid]]`, `[[wall]]` and `[domain]` blocks: the case
//! behind `case = "flow"` (the default).
//!
//! Effects: exactly those the scene declares — `[effects]` (gravity, viscosity, shifting),
//! `[free_surface]`, the walls of its `[[wall]]` blocks, periodic axes of its `[domain]`.
//! Records, besides the common columns: the fluid's centroid and pressure range; isolated
//! particles (fewer than three other fluid particles in the kernel support: fragmentation);
//! for a Taylor–Green velocity field the kinetic energy against its exact decay
//! `exp(−16π²νt/L²)`; for hydrostatic blocks the RMS pressure error against `ρ₀ |g| (top − z)`
//! relative to `ρ₀ |g| H`. Checks: the scene's `[[check]]` tables, on the run loop's results
//! (`max_wall_penetrations`, `reached_t`, `max_speed`, ...) and this case's ([`RESULTS`]).

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

/// The results of a flow run besides the run loop's.
pub const RESULTS: [&str; 8] = [
    "centroid_x",
    "centroid_y",
    "centroid_z",
    "isolated_particles_max",
    "kinetic_energy_change",
    "ke_decay_error_max",
    "hydrostatic_error",
    "hydrostatic_error_max",
];

/// The generic flow case.
pub struct FlowCase {
    scene: Scene,
    centroid: [f64; 3],
    /// Initial kinetic energy.
    ke0: f64,
    /// Exact kinetic-energy decay rate of a Taylor–Green field (`16π²ν/L²`), if the scene has one.
    ke_rate: Option<f64>,
    /// Hydrostatic reference: `(up, top, ρ₀|g|, H)`, if a block starts hydrostatic.
    hydro: Option<([f64; 3], f64, f64, f64)>,
    isolated_max: f64,
    ke_error_max: f64,
    ke_end: f64,
    hydro_error: f64,
    hydro_error_max: f64,
}

impl FlowCase {
    /// The flow of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let nu = scene.effects.viscosity.map_or(0.0, |v| v.nu);
        let ke_rate = scene.fluid.iter().find_map(|b| {
            b.velocity_field
                .as_ref()
                .filter(|f| f.kind == crate::blocks::FieldKind::TaylorGreen)
                .map(|f| {
                    let l = f.wavelength.unwrap_or(1.0);
                    16.0 * std::f64::consts::PI.powi(2) * nu / (l * l)
                })
        });
        Self {
            scene: scene.clone(),
            centroid: [f64::NAN; 3],
            ke0: f64::NAN,
            ke_rate,
            hydro: None,
            isolated_max: 0.0,
            ke_error_max: f64::NAN,
            ke_end: f64::NAN,
            hydro_error: f64::NAN,
            hydro_error_max: f64::NAN,
        }
    }
}

/// ½ Σ m u² over the fluid.
fn kinetic_energy<D: Dim>(sim: &Simulation<D>) -> f64 {
    let p = &sim.particles;
    let nf = sim.fluid_len();
    0.5 * p.masses[..nf]
        .iter()
        .zip(&p.velocities[..nf])
        .map(|(m, u)| m * u.length_squared())
        .sum::<f64>()
}

/// Fluid particles with fewer than three other fluid particles within the kernel support
/// (over the last projection's neighbour lists; 0 before the first step).
pub fn isolated_particles<D: Dim>(sim: &Simulation<D>) -> usize {
    let list = sim.neighbors();
    let nf = sim.fluid_len();
    if list.len() < nf {
        return 0;
    }
    (0..nf)
        .filter(|&i| {
            list.row(i)
                .iter()
                .filter(|&&j| (j as usize) < nf && j as usize != i)
                .count()
                < 3
        })
        .count()
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
            Column::new(
                "isolated_particles",
                "",
                "fluid particles with fewer than three other fluid particles in the support",
            ),
            Column::new(
                "ke_decay_error",
                "",
                "KE / (KE₀ exp(−16π²νt/L²)) − 1 (Taylor–Green fields only)",
            ),
            Column::new(
                "hydrostatic_error",
                "",
                "RMS of (p − ρ₀|g|(top − z)) / (ρ₀|g|H) over the fluid (hydrostatic blocks only)",
            ),
        ]
    }

    fn start(&mut self, sim: &Simulation<D>) -> Result<(), CaseError> {
        self.ke0 = kinetic_energy(sim);
        let hydrostatic = self.scene.fluid.iter().any(|b| b.hydrostatic);
        if let (true, Some(g)) = (hydrostatic, self.scene.effects.gravity) {
            let gv = D::Vector::from_fn(|k| g[k]);
            let gn = gv.length();
            if gn > 0.0 {
                let up = gv * (-1.0 / gn);
                let nf = sim.fluid_len();
                let (lo, hi) = sim.particles.positions[..nf]
                    .iter()
                    .map(|x| up.dot(*x))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                        (a.min(v), b.max(v))
                    });
                let top = hi + 0.5 * self.scene.dx;
                self.hydro = Some((
                    up.to_array3(),
                    top,
                    self.scene.rho0() * gn,
                    top - lo + 0.5 * self.scene.dx,
                ));
            }
        }
        Ok(())
    }

    fn observe(
        &mut self,
        sim: &Simulation<D>,
        report: Option<&StepReport>,
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
        let isolated = isolated_particles(sim) as f64;
        self.isolated_max = self.isolated_max.max(isolated);
        let ke = kinetic_energy(sim);
        self.ke_end = ke;
        let ke_error = self
            .ke_rate
            .map_or(f64::NAN, |r| ke / (self.ke0 * (-r * sim.t).exp()) - 1.0);
        self.ke_error_max = self.ke_error_max.max(ke_error.abs());
        // Not at the initial record: the initial pressure is the reference itself.
        let hydro =
            self.hydro
                .filter(|_| report.is_some())
                .map_or(f64::NAN, |(up, top, rho_g, h)| {
                    let up = D::Vector::from_fn(|k| up[k]);
                    let nf = sim.fluid_len();
                    let p = &sim.particles;
                    let sq: f64 = (0..nf)
                        .map(|i| {
                            let e = (p.pressures[i] - rho_g * (top - up.dot(p.positions[i])))
                                / (rho_g * h);
                            e * e
                        })
                        .sum();
                    (sq / nf.max(1) as f64).sqrt()
                });
        self.hydro_error = hydro;
        self.hydro_error_max = self.hydro_error_max.max(hydro);
        out.extend_from_slice(&[c[0], c[1], c[2], lo, hi, isolated, ke_error, hydro]);
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
        for (name, v) in [
            ("isolated_particles_max", self.isolated_max),
            (
                "kinetic_energy_change",
                if self.ke0 > 0.0 {
                    self.ke_end / self.ke0 - 1.0
                } else {
                    f64::NAN
                },
            ),
            ("ke_decay_error_max", self.ke_error_max),
            ("hydrostatic_error", self.hydro_error),
            ("hydrostatic_error_max", self.hydro_error_max),
        ] {
            results.insert(name.into(), v);
        }
        Ok(Finish {
            tables: Vec::new(),
            results,
        })
    }
}
