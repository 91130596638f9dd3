//! Any flow a scene poses with its `[[fluid]]`, `[[wall]]` and `[domain]` blocks: the case
//! behind `case = "flow"` (the default).
//!
//! Effects: exactly those the scene declares — `[effects]` (gravity, viscosity, shifting),
//! `[free_surface]`, the walls of its `[[wall]]` blocks, periodic axes of its `[domain]`.
//! Records, besides the common columns: the fluid's centroid and pressure range; isolated
//! particles (fewer than three other fluid particles in the kernel support: fragmentation);
//! for a Taylor–Green velocity field the kinetic energy against its exact decay
//! `exp(−16π²νt/L²)`; for hydrostatic blocks the RMS pressure error against `ρ₀ |g| (top − z)`
//! relative to `ρ₀ |g| H` (over the hydrostatic blocks' particles); the mechanical energy
//! `KE + M |g| (h_c − h_min)`; the area of voids the fluid encloses ([`enclosed_void_area`]).
//! Results ([`RESULTS`]) add the run's extremes: the largest isolated fraction and relative
//! kinetic-energy change, the mechanical energy's largest rise over its start; for still water
//! (all blocks hydrostatic) the largest speed over `√(gH)` and hydrostatic error once settled
//! (after `t √(g/H)` = [`SETTLED_AFTER`]) and the largest level change in `dx`; for a pool
//! (hydrostatic blocks) and fluid falling into it, when they first touch (`t_contact`) and the
//! pool's largest speed over `√(gH)` before; for a box in rigid rotation, the centre pressure
//! against the Poisson solution ([`rotating_rectangle_centre_pressure`]) after the first and
//! after [`CENTRE_PRESSURE_STEP`] steps. Checks: the scene's `[[check]]` tables, on the run
//! loop's results (`max_wall_penetrations`, `reached_t`, `max_speed`, ...) and these.

use crate::blocks::ChannelKind;
use crate::case::{Case, Column, Finish, Results, Setup};
use crate::{CaseError, Scene};
use sph_core::{Dim, VectorOps};
use sph_integrators::{Integrator, Scheme, Simulation, StepError, StepReport, WallCondition};

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
pub const RESULTS: [&str; 22] = [
    "centroid_x",
    "centroid_y",
    "centroid_z",
    "isolated_particles_max",
    "kinetic_energy_change",
    "ke_decay_error_max",
    "speed_decay_error_max",
    "hydrostatic_error",
    "hydrostatic_error_max",
    "isolated_fraction_max",
    "kinetic_energy_change_max",
    "energy_rise_max",
    "settled_speed_ratio",
    "settled_hydrostatic_error_max",
    "level_change_dx",
    "enclosed_void_area_max",
    "centre_pressure_error_first_step",
    "centre_pressure_error",
    "t_contact",
    "pool_speed_ratio_before_contact",
    "channel_centre_error_max",
    "channel_profile_error_max",
];

/// The start-up channel flows' exact velocity `u_x(y, t)`, `0 ≤ y ≤ L` from the lower plate,
/// from rest at `t = 0` with no slip at both plates, viscosity `ν` — the start-up flows Morris,
/// Fox & Zhu (1997) test their viscous term with. Poiseuille (both plates at rest, body force
/// `F` along x):
///
/// ```text
/// u = F y (L − y) / (2ν) − Σ_{n odd} 4 F L² / (ν π³ n³) · sin(nπy/L) · exp(−n²π²νt/L²)
/// ```
///
/// Couette (the upper plate at `U₀` from `t = 0`):
///
/// ```text
/// u = U₀ y / L + Σ_{n ≥ 1} 2 U₀ (−1)ⁿ / (nπ) · sin(nπy/L) · exp(−n²π²νt/L²)
/// ```
///
/// Both are derived here from `u_t = ν u_yy + F`: the steady profile less a decaying sine
/// series that cancels it at `t = 0` (`y (L − y)` has the coefficients `8L²/(n³π³)` for odd `n`,
/// `y/L` has `2(−1)ⁿ⁺¹/(nπ)`; tests check the equation, the plates and both limits). `drive` is
/// `F` or `U₀`. The series is summed until its terms fall below 1e-17 of the steady scale (at
/// most 10⁶ terms; `t > 0`).
pub fn channel_velocity(kind: ChannelKind, y: f64, t: f64, l: f64, nu: f64, drive: f64) -> f64 {
    use std::f64::consts::PI;
    let decay = PI * PI * nu * t / (l * l);
    let (mut u, scale) = match kind {
        ChannelKind::Poiseuille => {
            let steady = drive * y * (l - y) / (2.0 * nu);
            (steady, drive * l * l / (8.0 * nu))
        }
        ChannelKind::Couette => (drive * y / l, drive.abs()),
    };
    for n in 1..=1_000_000u32 {
        let nf = f64::from(n);
        let e = (-nf * nf * decay).exp();
        let term = match kind {
            ChannelKind::Poiseuille if n % 2 == 0 => continue,
            ChannelKind::Poiseuille => -4.0 * drive * l * l / (nu * PI.powi(3) * nf.powi(3)),
            ChannelKind::Couette => {
                let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
                2.0 * drive * sign / (nf * PI)
            }
        } * e;
        u += term * (nf * PI * y / l).sin();
        if term.abs() < 1e-17 * scale {
            break;
        }
    }
    u
}

/// A channel flow's errors at the current state, over the steady centreline speed (`F L²/8ν`,
/// or `U₀`): the mean `u_x` of the fluid particles within `dx/2` of the centreline against the
/// exact centreline speed, and the largest `|u_x,i − u(y_i, t)|` over the fluid.
fn channel_errors<D: Dim>(
    sim: &Simulation<D>,
    kind: ChannelKind,
    bottom: f64,
    l: f64,
    nu: f64,
    drive: f64,
    dx: f64,
) -> (f64, f64) {
    let scale = match kind {
        ChannelKind::Poiseuille => (drive * l * l / (8.0 * nu)).abs(),
        ChannelKind::Couette => drive.abs(),
    };
    let nf = sim.fluid_len();
    let (x, u) = (&sim.particles.positions, &sim.particles.velocities);
    let (mut sum, mut count, mut worst) = (0.0, 0usize, 0.0f64);
    for i in 0..nf {
        let y = x[i].get(1) - bottom;
        let exact = channel_velocity(kind, y, sim.t, l, nu, drive);
        worst = worst.max((u[i].get(0) - exact).abs());
        if (y - 0.5 * l).abs() <= 0.5 * dx {
            sum += u[i].get(0);
            count += 1;
        }
    }
    let centre = channel_velocity(kind, 0.5 * l, sim.t, l, nu, drive);
    let centre_error = if count > 0 {
        (sum / count as f64 - centre).abs() / scale
    } else {
        f64::NAN
    };
    (centre_error, worst / scale)
}

/// Still water counts as settled after `t √(g/H)` = this (the hard suite's criterion).
pub const SETTLED_AFTER: f64 = 20.0;

/// The step after which a rigid rotation's centre pressure is compared with the Poisson
/// solution (`centre_pressure_error`): Euler's first projection sees the divergence-free initial
/// field and gives `p = 0`, DG's first `det A − 1 = Δt² ω²` half the centripetal source; the
/// pressure of every scheme has caught up within a few steps.
pub const CENTRE_PRESSURE_STEP: usize = 10;

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
    /// Initial largest fluid speed (the Taylor–Green amplitude).
    speed0: f64,
    /// Largest |max speed / (speed₀ exp(−8π²νt/L²)) − 1| (Taylor–Green fields only).
    speed_error_max: f64,
    ke_end: f64,
    hydro_error: f64,
    hydro_error_max: f64,
    /// Fluid particles (for fractions).
    fluid: usize,
    ke_change_max: f64,
    /// Mechanical energy `KE + M |g| (h_c − h_min)` at the start and its largest rise.
    energy0: f64,
    energy_rise_max: f64,
    /// Total fluid mass and the lowest initial height (potential-energy reference).
    mass: f64,
    h_min: f64,
    /// `√(g/H)` and `√(gH)` of a hydrostatic start, and the settled window's maxima.
    settle_rate: f64,
    settle_speed: f64,
    settled_speed_max: f64,
    settled_hydro_max: f64,
    /// Centroid height at the start (level change of an all-hydrostatic fill).
    h_c0: f64,
    level_change: f64,
    all_hydrostatic: bool,
    /// Compute the enclosed-void area (2D flows with a free surface, or a check asks for it).
    voids: bool,
    void_max: f64,
    /// Rigid rotation in a box: the exact centre pressure and the particle (initial index)
    /// nearest the centre; the measured errors.
    centre_exact: Option<(f64, u32)>,
    centre_first: f64,
    centre_error: f64,
    /// `pool[id]`: the particle (initial numbering) belongs to a hydrostatic block.
    pool: Vec<bool>,
    /// The scene has hydrostatic and other blocks (a pool and what falls into it).
    pool_and_falling: bool,
    /// First record at which a falling particle has a pool particle in its support, and the
    /// pool's largest speed over `√(gH)` before it.
    t_contact: f64,
    pool_speed_max: f64,
    /// A start-up channel flow (`[channel]`): `(kind, bottom, L, ν, F or U₀)`, and the largest
    /// errors of the centreline speed and of the whole profile over the steady centreline
    /// speed.
    channel: Option<(ChannelKind, f64, f64, f64, f64)>,
    channel_centre_max: f64,
    channel_profile_max: f64,
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
            speed0: f64::NAN,
            speed_error_max: f64::NAN,
            ke_end: f64::NAN,
            hydro_error: f64::NAN,
            hydro_error_max: f64::NAN,
            fluid: 0,
            ke_change_max: f64::NAN,
            energy0: f64::NAN,
            energy_rise_max: f64::NAN,
            mass: 0.0,
            h_min: 0.0,
            settle_rate: f64::NAN,
            settle_speed: f64::NAN,
            settled_speed_max: f64::NAN,
            settled_hydro_max: f64::NAN,
            h_c0: f64::NAN,
            level_change: f64::NAN,
            all_hydrostatic: !scene.fluid.is_empty() && scene.fluid.iter().all(|b| b.hydrostatic),
            voids: scene
                .check
                .iter()
                .any(|c| c.quantity == "enclosed_void_area_max")
                || (scene.dim == 2 && scene.free_surface.is_some()),
            void_max: f64::NAN,
            centre_exact: None,
            centre_first: f64::NAN,
            centre_error: f64::NAN,
            pool: Vec::new(),
            pool_and_falling: false,
            t_contact: f64::NAN,
            pool_speed_max: f64::NAN,
            channel: scene.channel.map(|c| {
                let drive = match c.kind {
                    ChannelKind::Poiseuille => scene.effects.gravity.map_or(0.0, |g| g[0]),
                    ChannelKind::Couette => c.wall_speed.unwrap_or(0.0),
                };
                (c.kind, c.bottom.unwrap_or(0.0), c.height, nu, drive)
            }),
            channel_centre_max: f64::NAN,
            channel_profile_max: f64::NAN,
        }
    }

    /// Up (against gravity) and `|g|`, if the scene has gravity.
    fn up<D: Dim>(&self) -> Option<(D::Vector, f64)> {
        let g = self.scene.effects.gravity?;
        let gv = D::Vector::from_fn(|k| g[k]);
        let gn = gv.length();
        (gn > 0.0 && gn.is_finite()).then(|| (gv * (-1.0 / gn), gn))
    }

    /// `KE + M |g| (h_c − h_min)` (no potential term without gravity).
    fn mechanical_energy<D: Dim>(&self, sim: &Simulation<D>, ke: f64) -> f64 {
        match self.up::<D>() {
            Some((up, gn)) => ke + self.mass * gn * (up.dot(centroid(sim)) - self.h_min),
            None => ke,
        }
    }

    /// The pressure of the particle nearest a rigid rotation's centre.
    fn centre_pressure<D: Dim>(&self, sim: &Simulation<D>) -> Option<f64> {
        let (_, id) = self.centre_exact?;
        let slot = sim.ids().iter().position(|&k| k == id)?;
        Some(sim.particles.pressures[slot])
    }
}

/// Pressure at the centre of a rectangle `[−a, a] × [−b, b]` of fluid in rigid rotation at
/// `ω`, with `p = 0` on its edges: the Poisson problem `∇²p = 2ρω²` (for `u = ω e_z × x`,
/// `−ρ ∂_i u_j ∂_j u_i = 2ρω²`) solved by the series of the torsion function,
///
/// ```text
/// p(0, 0) = −2ρω² [a²/2 − (16 a²/π³) Σ_{n odd} (−1)^{(n−1)/2} / (n³ cosh(nπb/(2a)))]
/// ```
///
/// (separation of variables for `∇²u = −1`, `u = 0` on the edges; for a square the bracket is
/// `0.2946854 a²`, the torsion constant of a square bar).
pub fn rotating_rectangle_centre_pressure(a: f64, b: f64, rho: f64, omega: f64) -> f64 {
    use std::f64::consts::PI;
    let mut sum = 0.0;
    for k in 0..50 {
        let n = (2 * k + 1) as f64;
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        let c = (n * PI * b / (2.0 * a)).cosh();
        if !c.is_finite() {
            break;
        }
        sum += sign / (n * n * n * c);
    }
    let u0 = a * a / 2.0 - 16.0 * a * a / PI.powi(3) * sum;
    -2.0 * rho * omega * omega * u0
}

/// Area (volume in 3D) of the empty regions the fluid encloses, in units of `dx^D`: on a grid
/// of cells `dx/2` wide over the fluid's bounding box (two cells of margin), a cell is fluid
/// when a fluid particle lies within `1.1 dx` of its centre (so a lattice, and a single missing
/// particle in it, is all fluid); the empty cells that no path of empty cells connects to the
/// grid's edge are enclosed voids. Air trapped by the fluid alone (a closed air pocket, a hole
/// torn into a patch) counts; a gap between fluid and a wall does not (walls are not drawn).
pub fn enclosed_void_area<D: Dim>(x: &[D::Vector], dx: f64) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let c = 0.5 * dx;
    let r = 1.1 * dx;
    let mut lo = [0.0f64; 3];
    let mut n = [1usize; 3];
    for k in 0..D::DIM {
        let (a, b) = x
            .iter()
            .map(|p| p.get(k))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
        lo[k] = a - r - 2.0 * c;
        n[k] = (((b + r + 2.0 * c) - lo[k]) / c).ceil() as usize + 1;
    }
    let cells = n[0] * n[1] * n[2];
    // A grid beyond this many cells (a spray thrown far away) is not measured.
    if cells > 50_000_000 {
        return f64::NAN;
    }
    let index = |i: [usize; 3]| i[0] + n[0] * (i[1] + n[1] * i[2]);
    let mut fluid = vec![false; cells];
    let reach = (r / c).ceil() as i64;
    for p in x {
        let mut ci = [0i64; 3];
        for k in 0..D::DIM {
            ci[k] = ((p.get(k) - lo[k]) / c).floor() as i64;
        }
        let span = |k: usize| if k < D::DIM { -reach..=reach } else { 0..=0 };
        for dz in span(2) {
            for dy in span(1) {
                for dxi in span(0) {
                    let d = [dxi, dy, dz];
                    let mut cell = [0usize; 3];
                    let mut dist2 = 0.0;
                    let mut inside = true;
                    for k in 0..D::DIM {
                        let v = ci[k] + d[k];
                        if v < 0 || v >= n[k] as i64 {
                            inside = false;
                            break;
                        }
                        cell[k] = v as usize;
                        let centre = lo[k] + (v as f64 + 0.5) * c;
                        dist2 += (centre - p.get(k)).powi(2);
                    }
                    if inside && dist2 <= r * r {
                        fluid[index(cell)] = true;
                    }
                }
            }
        }
    }
    // Flood the empty cells from the grid's edge.
    let mut outside = vec![false; cells];
    let mut stack = Vec::new();
    for (k, (f, o)) in fluid.iter().zip(outside.iter_mut()).enumerate() {
        let i = [k % n[0], (k / n[0]) % n[1], k / (n[0] * n[1])];
        let edge = (0..D::DIM).any(|a| i[a] == 0 || i[a] + 1 == n[a]);
        if edge && !*f {
            *o = true;
            stack.push(i);
        }
    }
    while let Some(i) = stack.pop() {
        for a in 0..D::DIM {
            for step in [-1i64, 1] {
                let v = i[a] as i64 + step;
                if v < 0 || v >= n[a] as i64 {
                    continue;
                }
                let mut j = i;
                j[a] = v as usize;
                let k = index(j);
                if !fluid[k] && !outside[k] {
                    outside[k] = true;
                    stack.push(j);
                }
            }
        }
    }
    let voids = fluid
        .iter()
        .zip(&outside)
        .filter(|(f, o)| !**f && !**o)
        .count();
    voids as f64 * (c / dx).powi(D::DIM as i32)
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
    crate::case::state_fields!(
        centroid,
        ke0,
        ke_rate,
        hydro,
        isolated_max,
        ke_error_max,
        speed0,
        speed_error_max,
        ke_end,
        hydro_error,
        hydro_error_max,
        fluid,
        ke_change_max,
        energy0,
        energy_rise_max,
        mass,
        h_min,
        settle_rate,
        settle_speed,
        settled_speed_max,
        settled_hydro_max,
        h_c0,
        level_change,
        all_hydrostatic,
        voids,
        void_max,
        centre_exact,
        centre_first,
        centre_error,
        pool,
        pool_and_falling,
        t_contact,
        pool_speed_max,
        channel,
        channel_centre_max,
        channel_profile_max,
    );

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
            Column::new(
                "mechanical_energy",
                "energy",
                "KE + M |g| (h_c − h_min): kinetic plus potential energy of the fluid, heights \
                 from its lowest initial point (KE alone without gravity)",
            ),
            Column::new(
                "enclosed_void_area",
                "dx^D",
                "area (3D: volume) of the empty regions the fluid encloses (2D flows with a free \
                 surface, or when a check asks for enclosed_void_area_max)",
            ),
        ]
    }

    fn start(&mut self, sim: &Simulation<D>) -> Result<(), CaseError> {
        self.ke0 = kinetic_energy(sim);
        self.speed0 = sim.max_speed();
        let nf = sim.fluid_len();
        self.fluid = nf;
        self.mass = sim.particles.masses[..nf].iter().sum();
        if let Some((up, _)) = self.up::<D>() {
            self.h_min = sim.particles.positions[..nf]
                .iter()
                .map(|x| up.dot(*x))
                .fold(f64::INFINITY, f64::min);
            self.h_c0 = up.dot(centroid(sim));
        }
        self.energy0 = self.mechanical_energy(sim, self.ke0);
        self.energy_rise_max = if self.energy0 > 0.0 { 0.0 } else { f64::NAN };
        self.ke_change_max = if self.ke0 > 0.0 { 0.0 } else { f64::NAN };
        if D::DIM == 2 {
            self.centre_exact = self.scene.fluid.iter().find_map(|b| {
                let f = b.velocity_field.as_ref()?;
                if f.kind != crate::blocks::FieldKind::RigidRotation
                    || b.shape != crate::blocks::FluidShape::Box
                {
                    return None;
                }
                let (lo, hi) = (b.min.as_ref()?, b.max.as_ref()?);
                let omega = f.omega?;
                let centre = f
                    .center
                    .clone()
                    .unwrap_or_else(|| vec![0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])]);
                let exact = rotating_rectangle_centre_pressure(
                    0.5 * (hi[0] - lo[0]),
                    0.5 * (hi[1] - lo[1]),
                    self.scene.rho0(),
                    omega,
                );
                let c = D::Vector::from_fn(|k| centre.get(k).copied().unwrap_or(0.0));
                let nearest = (0..nf).min_by(|&i, &j| {
                    let (di, dj) = (
                        (sim.particles.positions[i] - c).length_squared(),
                        (sim.particles.positions[j] - c).length_squared(),
                    );
                    di.total_cmp(&dj)
                })?;
                Some((exact, sim.ids()[nearest]))
            });
        }
        // Which particles (initial numbering) belong to hydrostatic blocks: the pool.
        self.pool.clear();
        if self.scene.fluid.iter().any(|b| b.hydrostatic) {
            let condition = self
                .scene
                .wall_condition
                .unwrap_or(WallCondition::Continuation);
            let built = crate::geometry::build_blocks::<D>(
                &self.scene,
                &self.scene.fluid,
                &self.scene.wall,
                condition,
            )?;
            self.pool = built
                .block_of
                .iter()
                .map(|&b| self.scene.fluid[b].hydrostatic)
                .collect();
        }
        self.pool_and_falling = self.pool.iter().any(|p| *p) && self.pool.iter().any(|p| !*p);
        if let (false, Some((up, gn))) = (self.pool.is_empty(), self.up::<D>()) {
            let ids = sim.ids();
            let (lo, hi) = (0..nf)
                .filter(|&i| self.pool[ids[i] as usize])
                .map(|i| up.dot(sim.particles.positions[i]))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                    (a.min(v), b.max(v))
                });
            let top = hi + 0.5 * self.scene.dx;
            let depth = top - lo + 0.5 * self.scene.dx;
            self.hydro = Some((up.to_array3(), top, self.scene.rho0() * gn, depth));
            self.settle_rate = (gn / depth).sqrt();
            self.settle_speed = (gn * depth).sqrt();
            self.pool_speed_max = if self.pool_and_falling { 0.0 } else { f64::NAN };
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
        // The largest speed decays at half the energy's rate.
        let speed_error = self.ke_rate.map_or(f64::NAN, |r| {
            sim.max_speed() / (self.speed0 * (-0.5 * r * sim.t).exp()) - 1.0
        });
        self.speed_error_max = self.speed_error_max.max(speed_error.abs());
        // Not at the initial record: the initial pressure is the reference itself.
        let hydro =
            self.hydro
                .filter(|_| report.is_some())
                .map_or(f64::NAN, |(up, top, rho_g, h)| {
                    let up = D::Vector::from_fn(|k| up[k]);
                    let nf = sim.fluid_len();
                    let p = &sim.particles;
                    let ids = sim.ids();
                    let (sq, count) = (0..nf)
                        .filter(|&i| self.pool[ids[i] as usize])
                        .map(|i| {
                            let e = (p.pressures[i] - rho_g * (top - up.dot(p.positions[i])))
                                / (rho_g * h);
                            e * e
                        })
                        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
                    (sq / count.max(1) as f64).sqrt()
                });
        if self.pool_and_falling && self.t_contact.is_nan() {
            let nf = sim.fluid_len();
            let ids = sim.ids();
            let lists = sim.neighbors();
            let in_pool = |slot: usize| self.pool[ids[slot] as usize];
            let touching = lists.len() >= nf
                && (0..nf).any(|i| {
                    !in_pool(i)
                        && lists
                            .row(i)
                            .iter()
                            .any(|&j| (j as usize) < nf && in_pool(j as usize))
                });
            if touching {
                self.t_contact = sim.t;
            } else {
                let u = &sim.particles.velocities;
                let pool_speed = (0..nf)
                    .filter(|&i| in_pool(i))
                    .map(|i| u[i].length())
                    .fold(0.0, f64::max);
                self.pool_speed_max = self.pool_speed_max.max(pool_speed / self.settle_speed);
            }
        }
        self.hydro_error = hydro;
        self.hydro_error_max = self.hydro_error_max.max(hydro);
        if self.ke0 > 0.0 {
            self.ke_change_max = self.ke_change_max.max((ke / self.ke0 - 1.0).abs());
        }
        let energy = self.mechanical_energy(sim, ke);
        if self.energy0 > 0.0 {
            self.energy_rise_max = self.energy_rise_max.max(energy / self.energy0 - 1.0);
        }
        if self.settle_rate.is_finite() && sim.t * self.settle_rate >= SETTLED_AFTER {
            self.settled_speed_max = self
                .settled_speed_max
                .max(sim.max_speed() / self.settle_speed);
            self.settled_hydro_max = self.settled_hydro_max.max(hydro);
        }
        if self.all_hydrostatic
            && let Some((up, _)) = self.up::<D>()
        {
            let change = 2.0 * (up.dot(centroid(sim)) - self.h_c0) / self.scene.dx;
            self.level_change = self.level_change.max(change.abs());
        }
        let void = if self.voids {
            let nf = sim.fluid_len();
            enclosed_void_area::<D>(&sim.particles.positions[..nf], self.scene.dx)
        } else {
            f64::NAN
        };
        self.void_max = self.void_max.max(void);
        if let Some((kind, bottom, l, nu, drive)) = self.channel
            && sim.t > 0.0
        {
            let (centre, profile) = channel_errors(sim, kind, bottom, l, nu, drive, self.scene.dx);
            self.channel_centre_max = self.channel_centre_max.max(centre);
            self.channel_profile_max = self.channel_profile_max.max(profile);
        }
        out.extend_from_slice(&[
            c[0], c[1], c[2], lo, hi, isolated, ke_error, hydro, energy, void,
        ]);
        Ok(())
    }

    fn advance(
        &mut self,
        sim: &mut Simulation<D>,
        scheme: &mut Scheme,
        dt: f64,
    ) -> Result<StepReport, StepError> {
        let report = scheme.step(sim, dt)?;
        if let Some((exact, _)) = self.centre_exact {
            let error = self
                .centre_pressure(sim)
                .map_or(f64::NAN, |p| p / exact - 1.0);
            if sim.step == 1 {
                self.centre_first = error;
            }
            if sim.step == CENTRE_PRESSURE_STEP {
                self.centre_error = error;
            }
        }
        Ok(report)
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
            ("speed_decay_error_max", self.speed_error_max),
            ("hydrostatic_error", self.hydro_error),
            ("hydrostatic_error_max", self.hydro_error_max),
            (
                "isolated_fraction_max",
                self.isolated_max / self.fluid.max(1) as f64,
            ),
            ("kinetic_energy_change_max", self.ke_change_max),
            ("energy_rise_max", self.energy_rise_max),
            ("settled_speed_ratio", self.settled_speed_max),
            ("settled_hydrostatic_error_max", self.settled_hydro_max),
            ("level_change_dx", self.level_change),
            ("enclosed_void_area_max", self.void_max),
            ("centre_pressure_error_first_step", self.centre_first),
            ("centre_pressure_error", self.centre_error),
            ("t_contact", self.t_contact),
            ("channel_centre_error_max", self.channel_centre_max),
            ("channel_profile_error_max", self.channel_profile_max),
            ("pool_speed_ratio_before_contact", self.pool_speed_max),
        ] {
            results.insert(name.into(), v);
        }
        Ok(Finish {
            tables: Vec::new(),
            results,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sph_core::testing::lattice;

    /// `∇²u = −1` on `[−a, a] × [−b, b]`, `u = 0` on the edges, by second-order finite
    /// differences (`m` cells along `x`, Gauss–Seidel with over-relaxation): the centre value.
    fn poisson_centre(a: f64, b: f64, m: usize) -> f64 {
        let h = 2.0 * a / m as f64;
        let mb = (2.0 * b / h).round() as usize;
        let mut u = vec![0.0; (m + 1) * (mb + 1)];
        let at = |i: usize, j: usize| i + (m + 1) * j;
        let omega = 2.0 / (1.0 + (std::f64::consts::PI / m.max(mb) as f64).sin());
        for _ in 0..4000 {
            for j in 1..mb {
                for i in 1..m {
                    let gs = 0.25
                        * (u[at(i - 1, j)]
                            + u[at(i + 1, j)]
                            + u[at(i, j - 1)]
                            + u[at(i, j + 1)]
                            + h * h);
                    u[at(i, j)] += omega * (gs - u[at(i, j)]);
                }
            }
        }
        u[at(m / 2, mb / 2)]
    }

    /// The series for the rotating rectangle's centre pressure agrees with a finite-difference
    /// solution of the same Poisson problem (square and 2:1 rectangle), and the square's value
    /// is the torsion constant 0.2946854 a² (times −2ρω²).
    #[test]
    fn rotating_rectangle_centre_pressure_solves_the_poisson_problem() {
        for (a, b) in [(0.5, 0.5), (0.5, 1.0)] {
            let series = rotating_rectangle_centre_pressure(a, b, 1.0, 1.0);
            let fd = -2.0 * poisson_centre(a, b, 64);
            assert!(
                (series / fd - 1.0).abs() < 1e-3,
                "{a} × {b}: series {series}, finite differences {fd}"
            );
        }
        let square = rotating_rectangle_centre_pressure(0.5, 0.5, 1.0, 1.0);
        assert!(
            (square / (-2.0 * 0.2946854 * 0.25) - 1.0).abs() < 1e-6,
            "{square}"
        );
        // ρ and ω scale it as ρ ω².
        let scaled = rotating_rectangle_centre_pressure(0.5, 0.5, 2.0, 3.0);
        assert!((scaled / (18.0 * square) - 1.0).abs() < 1e-12);
    }

    sph_core::dim_tests! {
        /// A lattice block encloses no void, nor does it with one particle missing or with a
        /// notch cut from its side; a hole of radius 3 dx cut from its middle is one enclosed
        /// void whose measured size is the hole less the band within 1.1 dx of its rim.
        fn enclosed_voids_are_holes_in_the_fluid<D>() {
            let per_side = if D::DIM == 2 { 24 } else { 14 };
            let dx = 1.0 / per_side as f64;
            let block = lattice::<D>(per_side, dx);
            assert_eq!(enclosed_void_area::<D>(&block, dx), 0.0);
            let mut one_gone = block.clone();
            let centre = (0..one_gone.len())
                .min_by(|&i, &j| one_gone[i].length().total_cmp(&one_gone[j].length()))
                .unwrap();
            one_gone.remove(centre);
            assert_eq!(enclosed_void_area::<D>(&one_gone, dx), 0.0, "a vacancy is no void");
            let notch: Vec<D::Vector> = block
                .iter()
                .copied()
                .filter(|x| !(x.get(0) > 0.2 && x.get(1).abs() < 4.0 * dx))
                .collect();
            assert_eq!(enclosed_void_area::<D>(&notch, dx), 0.0, "a notch open to the outside");
            let r = 3.0 * dx;
            let holed: Vec<D::Vector> = block.iter().copied().filter(|x| x.length() > r).collect();
            let area = enclosed_void_area::<D>(&holed, dx);
            // The void is what lies farther than 1.1 dx from every particle: it holds the ball
            // of radius r − 1.1 dx and lies within the removed ball (its lattice sites reach
            // out to r + √D dx / 2).
            let ball = |radius: f64| {
                if D::DIM == 2 {
                    std::f64::consts::PI * radius * radius
                } else {
                    4.0 / 3.0 * std::f64::consts::PI * radius.powi(3)
                }
            };
            let (lower, upper) = (
                0.9 * ball(r / dx - 1.1),
                ball(r / dx + 0.5 * (D::DIM as f64).sqrt()),
            );
            assert!(area >= lower && area <= upper, "area {area}, expected {lower} to {upper}");
        }
    }
}

#[cfg(test)]
mod channel_tests {
    use super::channel_velocity;
    use crate::blocks::ChannelKind;

    /// The series solves `u_t = ν u_yy + F` (centred differences), is 0 on both plates (the
    /// upper one moving at `U₀` for Couette), starts from rest and ends at the steady profile.
    #[test]
    fn the_channel_series_solves_the_start_up_problem() {
        let (l, nu) = (1e-3, 1e-6);
        for (kind, drive) in [
            (ChannelKind::Poiseuille, 2e-4),
            (ChannelKind::Couette, 2.5e-5),
        ] {
            let u = |y: f64, t: f64| channel_velocity(kind, y, t, l, nu, drive);
            let force = if kind == ChannelKind::Poiseuille {
                drive
            } else {
                0.0
            };
            let scale = 2.5e-5;
            for &t in &[0.01, 0.05, 0.2] {
                for &y in &[0.2 * l, 0.5 * l, 0.77 * l] {
                    let (dy, dt) = (1e-3 * l, 1e-4 * t);
                    let u_t = (u(y, t + dt) - u(y, t - dt)) / (2.0 * dt);
                    let u_yy = (u(y + dy, t) - 2.0 * u(y, t) + u(y - dy, t)) / (dy * dy);
                    let residual = (u_t - nu * u_yy - force).abs();
                    let size = u_t.abs() + (nu * u_yy).abs() + force;
                    assert!(
                        residual < 1e-4 * size,
                        "{kind:?} y {y} t {t}: {residual:e} of {size:e}"
                    );
                }
                assert!(u(0.0, t).abs() < 1e-12 * scale, "{kind:?}: lower plate");
                let top = if kind == ChannelKind::Couette {
                    drive
                } else {
                    0.0
                };
                assert!(
                    (u(l, t) - top).abs() < 1e-9 * scale,
                    "{kind:?}: upper plate {}",
                    u(l, t)
                );
            }
            // From rest (the series at a very small time) to the steady profile.
            assert!(
                u(0.5 * l, 1e-9).abs() < 1e-3 * scale,
                "{kind:?}: {}",
                u(0.5 * l, 1e-9)
            );
            let steady = if kind == ChannelKind::Poiseuille {
                drive * l * l / (8.0 * nu)
            } else {
                0.5 * drive
            };
            assert!(
                (u(0.5 * l, 50.0) - steady).abs() < 1e-12 * scale,
                "{kind:?}"
            );
        }
    }
}
