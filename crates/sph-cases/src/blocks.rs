//! The geometry and output tables of a scene: `[[fluid]]`, `[[wall]]`, `[domain]`, `[output]`,
//! `[limits]` and `[[check]]`. Each table is a plain `serde` struct that refuses unknown keys;
//! [`Scene::validate`](crate::Scene::validate) checks the values and names the key of the first
//! bad one (`fluid[1].radius`, `wall[0].open`, ...).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The shape of a `[[fluid]]` block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FluidShape {
    /// Axis-aligned box `min ≤ x ≤ max`.
    Box,
    /// Ellipse (2D) or ellipsoid (3D) with `center` and `semi_axes`.
    Ellipse,
    /// Ellipsoid: the same as `ellipse`.
    Ellipsoid,
    /// Circle (2D) or sphere (3D) with `center` and `radius`.
    Circle,
    /// Sphere: the same as `circle`.
    Sphere,
    /// Simple polygon (2D only) with `vertices` in order.
    Polygon,
}

/// Where a block's lattice sits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LatticeKind {
    /// Points at `(k + ½) dx` along every axis: the lattice the walls use, so a box whose faces
    /// lie on multiples of `dx` fills exactly with particles `dx/2` inside its faces. Default.
    #[default]
    Staggered,
    /// Points at `center + k dx`: a particle sits at the block's centre (the paper's drops).
    Centered,
}

/// A named initial velocity field.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FieldKind {
    /// Rigid rotation `u = ω e_z × (x − center)` (in the x–y plane).
    RigidRotation,
    /// The Taylor–Green vortex `u = −U cos(2πx/L) sin(2πy/L)`, `v = U sin(2πx/L) cos(2πy/L)`
    /// (in the x–y plane; `w = 0` in 3D), a steady solution of the Euler equations that decays
    /// viscously as `exp(−8π²νt/L²)`.
    TaylorGreen,
}

/// `velocity_field = { kind = ..., ... }` of a fluid block.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VelocityField {
    /// Which field.
    pub kind: FieldKind,
    /// Rigid rotation: angular velocity `ω` (rad per unit time, counter-clockwise).
    pub omega: Option<f64>,
    /// Rigid rotation: centre (default: the block's centre).
    pub center: Option<Vec<f64>>,
    /// Taylor–Green: amplitude `U` (default 1).
    pub amplitude: Option<f64>,
    /// Taylor–Green: wavelength `L` (default 1).
    pub wavelength: Option<f64>,
}

/// A `[[fluid]]` block: a shape filled with particles on the scene's lattice, with an initial
/// velocity and (optionally) hydrostatic pressure. Points of later blocks that an earlier block
/// already holds, and points in wall material, are left out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FluidBlock {
    /// Shape.
    pub shape: FluidShape,
    /// Box: lower corner.
    pub min: Option<Vec<f64>>,
    /// Box: upper corner.
    pub max: Option<Vec<f64>>,
    /// Ellipse, circle: centre.
    pub center: Option<Vec<f64>>,
    /// Ellipse: semi-axes along x, y (, z).
    pub semi_axes: Option<Vec<f64>>,
    /// Circle: radius.
    pub radius: Option<f64>,
    /// Polygon: vertices `[[x, y], ...]` in order (2D; a vertex with another number of
    /// coordinates is an error, not truncated).
    #[serde(default, deserialize_with = "vertex_pairs")]
    pub vertices: Option<Vec<[f64; 2]>>,
    /// Lattice placement. Default `staggered`.
    #[serde(default)]
    pub lattice: LatticeKind,
    /// Constant initial velocity (added to the other two). Default 0.
    pub velocity: Option<Vec<f64>>,
    /// Linear initial velocity `u = G (x − c)` with `c` the block's centre (`G` row by row).
    pub velocity_gradient: Option<Vec<Vec<f64>>>,
    /// A named initial velocity field.
    pub velocity_field: Option<VelocityField>,
    /// Initial pressure `ρ₀ g·(x − x_top)`, hydrostatic under the scene's gravity, with
    /// `x_top` the block's highest point against gravity (its free surface). Needs gravity.
    #[serde(default)]
    pub hydrostatic: bool,
    /// Random displacement of each particle by up to this fraction of `dx` per axis (a
    /// disordered start; seeded, so runs repeat). Default 0.
    pub jitter: Option<f64>,
}

/// Polygon vertices, each exactly `[x, y]`.
fn vertex_pairs<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Vec<[f64; 2]>>, D::Error> {
    use serde::de::Error;
    let v: Option<Vec<Vec<f64>>> = Option::deserialize(d)?;
    v.map(|v| {
        v.iter()
            .enumerate()
            .map(|(i, p)| {
                <[f64; 2]>::try_from(p.as_slice()).map_err(|_| {
                    D::Error::custom(format!(
                        "vertex {i} has {} coordinates; a polygon is 2D: [x, y]",
                        p.len()
                    ))
                })
            })
            .collect()
    })
    .transpose()
}

/// What a `[[wall]]` box does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WallKind {
    /// The fluid stays inside; wall particles lie outside the closed faces. Default.
    #[default]
    Container,
    /// The fluid stays outside; wall particles fill the box.
    Solid,
}

/// The shape of a wall (boxes only, for now).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WallShape {
    /// Axis-aligned box.
    #[default]
    Box,
}

/// A `[[wall]]` block: fixed dummy wall particles on the scene's lattice (Adami et al. 2012),
/// as many layers as the kernel support needs, for a container (open faces allowed) or a solid
/// obstacle. `velocity` and `face_velocity` are velocities of the wall's surface (a lid, a
/// belt): the wall particles carry them into the no-slip and wall conditions but do not move.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallBlock {
    /// Shape (`box`).
    #[serde(default)]
    pub shape: WallShape,
    /// Container (default) or solid.
    #[serde(default)]
    pub kind: WallKind,
    /// Lower corner of the box.
    pub min: Vec<f64>,
    /// Upper corner.
    pub max: Vec<f64>,
    /// Container faces without a wall: `"-x"`, `"+x"`, `"-y"`, `"+y"`, `"-z"`, `"+z"`.
    #[serde(default)]
    pub open: Vec<String>,
    /// Layers of wall particles. Default: enough to fill the kernel support.
    pub layers: Option<usize>,
    /// Surface velocity of the whole wall. Default 0.
    pub velocity: Option<Vec<f64>>,
    /// Surface velocity of single container faces, e.g. `{ "+y" = [1.0, 0.0] }` (a lid: the wall
    /// particles beyond that face within the box's extent along the other axes).
    #[serde(default)]
    pub face_velocity: BTreeMap<String, Vec<f64>>,
}

/// `[domain]`: the periodic box.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DomainSpec {
    /// Lower corner of the periodic box.
    pub min: Option<Vec<f64>>,
    /// Upper corner.
    pub max: Option<Vec<f64>>,
    /// Periodic axes: any of `"x"`, `"y"`, `"z"`.
    #[serde(default)]
    pub periodic: Vec<String>,
}

/// A per-step diagnostic a scene can ask for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DiagnosticKind {
    /// `det F` of each step (min, mean, max; and per particle in frames).
    DetF,
    /// `max |∇·u|` after each projection.
    DivU,
}

/// `[output]`: what a run records and writes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Per-step diagnostics (each costs a pass). Default: none.
    #[serde(default)]
    pub diagnostics: Vec<DiagnosticKind>,
    /// Steps between records. Default: the case's (every step for the drops, ~400 records per
    /// run for the cavity and flows).
    pub sample_every: Option<usize>,
    /// Times at which a record and the case's snapshot tables are written.
    #[serde(default)]
    pub snapshots: Vec<f64>,
    /// Records between particle frames (MCAP, VTK). Default: the case's.
    pub frame_every: Option<usize>,
    /// Write ParaView files (`.vtp` per frame and a `.pvd` index). Default false.
    #[serde(default)]
    pub vtk: bool,
}

/// `[channel]` (`flow`): a start-up flow between two plates normal to y, from rest, measured
/// against its series solution ([`channel_velocity`](crate::flow::channel_velocity)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSpec {
    /// `poiseuille` (driven by the scene's gravity along x, both plates at rest) or `couette`
    /// (the upper plate moves at `wall_speed` along x from t = 0).
    pub kind: ChannelKind,
    /// y of the lower plate's face. Default 0.
    pub bottom: Option<f64>,
    /// The gap `L` between the plates' faces.
    pub height: f64,
    /// Couette: the upper plate's speed.
    pub wall_speed: Option<f64>,
}

/// Which start-up channel flow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ChannelKind {
    /// Body force `F` along x between plates at rest.
    Poiseuille,
    /// The upper plate sliding at `U₀` along x.
    Couette,
}

/// `[start]`: how the initial state is prepared before the clock starts.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartSpec {
    /// Settle the initial state with this many steps of the scheme before `t = 0`, each ending
    /// with the fraction `settle_damping` of the fluid's velocity removed (dynamic relaxation),
    /// and start from rest in the settled positions with the settled pressure. Nothing is
    /// recorded while settling. Default 0 (none).
    pub settle_steps: Option<usize>,
    /// The fraction `c` of the fluid's velocity removed at the end of each settling step, in
    /// `(0, 1]`: the settling is the scheme's dynamics damped at the rate `c/Δt`. Default 1: each
    /// step ends at rest, and moves a particle by only `Δt²` times its acceleration (a jitter
    /// is not undone: `relax_iterations` packs it). With `c` near `2ωΔt` the surface waves of
    /// frequency `ω` (a jittered surface's: `ω = √(π g/Δx)`) are damped critically.
    pub settle_damping: Option<f64>,
    /// Pack the fluid particles with this many fixed-coefficient shifting iterations before
    /// anything else (positions only; `sph_integrators::Simulation::relax`): a disordered start
    /// (`jitter`) loses the disorder that makes the approximate projection amplify. Default 0.
    pub relax_iterations: Option<usize>,
}

/// `[limits]`: what a scene may allocate and how a blow-up is recognised.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsSpec {
    /// Largest particle count (fluid and walls) the scene may create. Default 4 000 000.
    pub max_particles: Option<usize>,
    /// Largest estimated memory of one run, in GiB. Default 8.
    pub max_memory_gb: Option<f64>,
    /// Largest number of steps. Default 10 000 000.
    pub max_steps: Option<usize>,
    /// Largest displacement of a particle in one step, in smoothing lengths. Default 1.
    pub max_displacement: Option<f64>,
    /// Largest fluid speed over the flow's velocity scale (the `max_speed_ratio` result's `U`)
    /// before the run is stopped as a blow-up. Default [`DEFAULT_MAX_SPEED_RATIO`].
    pub max_speed_ratio: Option<f64>,
}

/// The default `[limits] max_speed_ratio`: healthy flows of the hard suite stay under 4 times
/// their velocity scale (the splash of a drop on a wall, the jets of the dam break's impact),
/// blown-up ones pass 100 and more; a run whose speeds have run away to 50 times the scale is
/// stopped rather than followed with ever smaller automatic steps.
pub const DEFAULT_MAX_SPEED_RATIO: f64 = 50.0;

impl LimitsSpec {
    /// The particle limit (default 4 000 000).
    pub fn particles(&self) -> usize {
        self.max_particles.unwrap_or(4_000_000)
    }
    /// The memory limit in bytes (default 8 GiB).
    pub fn memory_bytes(&self) -> f64 {
        self.max_memory_gb.unwrap_or(8.0) * (1u64 << 30) as f64
    }
    /// The step limit (default 10 000 000).
    pub fn steps(&self) -> usize {
        self.max_steps.unwrap_or(10_000_000)
    }
    /// The speed-ratio limit (default [`DEFAULT_MAX_SPEED_RATIO`]).
    pub fn speed_ratio(&self) -> f64 {
        self.max_speed_ratio.unwrap_or(DEFAULT_MAX_SPEED_RATIO)
    }
}

/// A `[[check]]`: a pass criterion on a named result of the run, declared before the run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckSpec {
    /// The result checked (see the case's results, e.g. `max_wall_penetrations`,
    /// `front_error_max`, `reached_t`).
    pub quantity: String,
    /// Passes when the value is at most this.
    pub max: Option<f64>,
    /// Passes when the value is at least this.
    pub min: Option<f64>,
    /// Only for these schemes (default: every scheme).
    #[serde(default)]
    pub schemes: Vec<sph_integrators::SchemeKind>,
    /// Where the criterion comes from (shown in reports).
    pub source: Option<String>,
    /// Declares the check a known failure, saying why: it is still measured and reported, as
    /// `known failure` (or `pass (known failure passed)`), but does not fail a validation. The
    /// bounds stay what they were; a known failure on `completed` covers a failed run.
    pub known_failure: Option<String>,
}

/// Axis index of `"x"`, `"y"`, `"z"`.
pub fn axis_index(name: &str) -> Option<usize> {
    match name {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        _ => None,
    }
}

/// `(axis, upper)` of a face name `"-x"`, `"+y"`, ...
pub fn face_index(name: &str) -> Option<(usize, bool)> {
    // Split after the first character, not the first byte: a face named with a multi-byte
    // character ("é+y") is an unknown face, not a panic.
    let cut = name.chars().next().map_or(0, char::len_utf8);
    let (sign, axis) = name.split_at(cut);
    let upper = match sign {
        "+" => true,
        "-" => false,
        _ => return None,
    };
    Some((axis_index(axis)?, upper))
}

/// `[free_surface]`: the free surface and how it is found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreeSurfaceSpec {
    /// `∇·r` below which a particle is on the free surface (Dirichlet `p = 0`). Default 0.75 d
    /// (1.5 in 2D, the paper's Ref. \[17\]; 2.25 in 3D).
    pub div_r_threshold: Option<f64>,
    /// Also flag particles whose umbrella region outside them is empty (Marrone et al. 2010).
    /// Default: on for `flow` scenes, off for the paper's drops (the paper uses `∇·r` alone).
    pub scan: Option<bool>,
    /// Put `p = 0` half a particle spacing outside the free-surface particles, where a
    /// lattice's fluid ends (a Robin row), instead of at them (the paper's Dirichlet rows).
    /// Default: on for `flow` and `dam_break` scenes with the symmetric gradient and its level
    /// term (their defaults), off otherwise.
    pub extrapolate: Option<bool>,
    /// Complete the pressure rows of the particles in the surface's band (a free-surface
    /// particle in their support, not flagged themselves) with the neighbours a lattice would
    /// have beyond a flat surface at their depth, read as air at `p = 0`, instead of as no
    /// flux into the air. Default: on where the surface rows are Robin rows (`extrapolate`).
    pub complete_band: Option<bool>,
    /// Put the `p = 0` of each surface particle whose last pressure is positive at the distance
    /// its truncation says it stands below a flat surface (half a spacing on a lattice's top
    /// row, more for a particle sunk into the row below, at most one spacing) instead of half a
    /// spacing for all. Default: on with the Robin rows (`extrapolate`).
    pub measured_depth: Option<bool>,
}

/// The pressure-gradient form of the velocity correction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GradientChoice {
    /// `Σ_j V_j (p_j − p_i) ∇W_ij`: exact for linear pressures once renormalised.
    Difference,
    /// `Σ_j V_j (p_i + p_j) ∇W_ij`: without renormalisation the negative adjoint of the
    /// divergence, so the projection does not create kinetic energy.
    Symmetric,
    /// `Σ_j V_j (p_i L_i + p_j L_j) ∇W_ij`: the negative adjoint of the renormalised
    /// divergence (needs `renormalise`).
    Adjoint,
}

/// `[pressure]`: the discrete operators of the projection. Defaults depend on the case: the
/// paper's cases use the paper's operators (`difference`, renormalised); `flow` scenes use the
/// conservative pair (`symmetric`, not renormalised), which stays free of the spurious energy
/// the non-adjoint pair injects at impacts and fronts (`docs/physics.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PressureSpec {
    /// Pressure-gradient form.
    pub gradient: Option<GradientChoice>,
    /// Kernel-gradient renormalisation of the divergence, the velocity gradient and the
    /// pressure gradient.
    pub renormalise: Option<bool>,
    /// Make the Laplacian (DG: the Hessian) exact for linear fields (Fatehi & Manzari 2011), so
    /// hydrostatic pressure is a discrete solution on a disordered particle set. Needs
    /// `renormalise`. Default false.
    pub consistent_laplacian: Option<bool>,
    /// Complete the pressure equation with the divergence of the symmetric gradient's
    /// constant-pressure part, so the projection is consistent at any pressure level (see
    /// `sph_pressure::add_level_term`). Only with the symmetric gradient, not renormalised.
    /// Default: true where that is the gradient (flow and dam-break scenes), false otherwise.
    pub level_consistent: Option<bool>,
    /// Divide each fluid particle's pressure gradient by `∇·r_i / D` away from the free
    /// surface, so the velocity correction applies the gradient the Laplacian stands for (see
    /// `sph_integrators::SimConfig::normalised_gradient`). Not with `renormalise`. Default: true
    /// for `flow` and `dam_break` scenes without renormalisation, false otherwise.
    pub normalise_gradient: Option<bool>,
    /// Density relaxation `α` in [0, 1] (Asai et al. 2012): the projection pulls each
    /// particle's summation density back towards the lattice's by the fraction `α` of its
    /// error per step (away from free surfaces). Default: `FLOW_DENSITY_RELAXATION` (0.05) for
    /// `flow` and `dam_break` scenes, 0 (off) for the paper's cases.
    pub density_relaxation: Option<f64>,
    /// How the relaxation acts: `"velocity"` (the projection's target divergence) or
    /// `"position"` (a second Poisson solve displaces the particles, velocities untouched;
    /// the default of `flow` and `dam_break` scenes).
    pub density_relaxation_form: Option<sph_integrators::DensityRelaxationForm>,
}
