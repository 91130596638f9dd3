//! Scene files: TOML under the repository's `cases/` directory (every key: `docs/scenes.md`).
//!
//! ```toml
//! case = "flow"                  # flow (default) | dam_break | the paper's cases, see CaseKind
//! dim = 2
//! dx = 0.02                      # initial particle spacing (the lattice of every block)
//! kernel = "wendland_c2"         # quintic_spline (default) | wendland_c2 | cubic_spline
//! dt = 1e-3                      # fixed time step
//! t_end = 1.0
//! schemes = ["dg"]
//! [[fluid]]                      # box | ellipse | circle | polygon, filled on the lattice
//! shape = "box"
//! min = [0.0, 0.0]
//! max = [0.5, 1.0]
//! [[wall]]                       # containers (faces may be open) and solid obstacles
//! min = [0.0, 0.0]
//! max = [2.0, 1.5]
//! open = ["+y"]
//! [free_surface]                 # absent: no free surface (no Dirichlet rows)
//! div_r_threshold = 1.5
//! [effects]                      # absent effects are not computed
//! gravity = [0.0, -9.81, 0.0]
//! ```
//!
//! Unknown keys are errors, every value is range-checked by [`Scene::validate`] (errors name
//! the key), and what a scene would allocate is bounded before anything is allocated
//! ([`Scene::estimate`]).

use crate::CaseError;
use crate::blocks::{
    ChannelKind, ChannelSpec, CheckSpec, DiagnosticKind, DomainSpec, FluidBlock, FluidShape,
    FreeSurfaceSpec, GradientChoice, LimitsSpec, OutputSpec, PressureSpec, StartSpec, WallBlock,
    WallKind, axis_index, face_index,
};
use serde::{Deserialize, Serialize};
use sph_integrators::{
    AutoTimeStep, DensityRelaxationForm, Diagnostics, DtBound, Effects, FreeSurface,
    Hyperviscosity, HyperviscousRegion, Limits, PeriodicAxes, SchemeKind, ShiftScale,
    ShiftVelocity, Shifting, SimConfig, Viscosity, ViscousOperator, WallCondition,
};
use sph_kernels::KernelKind;
use sph_operators::HessianForm;
use sph_pressure::SolverKind;

/// Which case a scene runs: what it measures and checks. `flow` and `dam_break` take their
/// geometry from the scene's `[[fluid]]` and `[[wall]]` blocks; the paper's cases build theirs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CaseKind {
    /// Any flow posed by the scene's blocks: records kinetic energy, volume, penetrations; checks
    /// what the scene's `[[check]]` tables declare. The default.
    #[default]
    Flow,
    /// A collapsing water column (Martin & Moyce 1952): the scene's first fluid block is the
    /// column; records the surge front and compares it with the experiment.
    DamBreak,
    /// 2D free-surface drop of the paper's Section 5 (Eq. 29).
    EllipticalDrop,
    /// 3D free-surface prolate spheroid of Section 5 (Eq. 30).
    SpheroidDrop,
    /// 2D particles advected by a prescribed linear field (Section 3, Eq. 14).
    PrescribedEllipse,
    /// 3D particles advected by a prescribed linear field (Section 3, Eq. 15).
    PrescribedEllipsoid,
    /// Lid-driven cavity (Section 6): unit square (2D) or cube (3D), walls of dummy particles,
    /// lid `y = 1` moving in `+x`.
    LidDrivenCavity,
}

impl CaseKind {
    /// Every case.
    pub const ALL: [CaseKind; 7] = [
        CaseKind::Flow,
        CaseKind::DamBreak,
        CaseKind::EllipticalDrop,
        CaseKind::SpheroidDrop,
        CaseKind::PrescribedEllipse,
        CaseKind::PrescribedEllipsoid,
        CaseKind::LidDrivenCavity,
    ];

    /// The case name as written in scene files.
    pub fn name(self) -> &'static str {
        match self {
            CaseKind::Flow => "flow",
            CaseKind::DamBreak => "dam_break",
            CaseKind::EllipticalDrop => "elliptical_drop",
            CaseKind::SpheroidDrop => "spheroid_drop",
            CaseKind::PrescribedEllipse => "prescribed_ellipse",
            CaseKind::PrescribedEllipsoid => "prescribed_ellipsoid",
            CaseKind::LidDrivenCavity => "lid_driven_cavity",
        }
    }

    /// The dimension the case is defined in (the default of those that run in both: 2).
    pub fn dim(self) -> usize {
        match self {
            CaseKind::SpheroidDrop | CaseKind::PrescribedEllipsoid => 3,
            _ => 2,
        }
    }

    /// Whether the case can run in `dim` dimensions.
    pub fn supports_dim(self, dim: usize) -> bool {
        match self {
            CaseKind::LidDrivenCavity | CaseKind::Flow | CaseKind::DamBreak => dim == 2 || dim == 3,
            _ => dim == self.dim(),
        }
    }

    /// Whether the scene's `[[fluid]]`/`[[wall]]`/`[domain]` blocks pose the geometry.
    pub fn uses_blocks(self) -> bool {
        matches!(self, CaseKind::Flow | CaseKind::DamBreak)
    }
}

/// Parameters of the lid-driven cavity (`[cavity]` in a scene).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CavitySpec {
    /// Reynolds number `U L / ν` (L = 1); sets the viscosity.
    pub reynolds: f64,
    /// Lid speed `U`. Default 1.
    #[serde(default = "one")]
    pub lid_speed: f64,
    /// Layers of wall particles. Default: enough to fill the kernel support.
    pub wall_layers: Option<usize>,
    /// Spacing of the uniform probe array of the density error (Eq. 31). Default `dx`.
    pub probe_spacing: Option<f64>,
    /// Times at which the density-error field is written. Default none.
    #[serde(default)]
    pub snapshots: Vec<f64>,
    /// Steps between time-series records. Default: about 400 records per run.
    pub sample_every: Option<usize>,
    /// Ghia comparison tolerances `[rms, max]` of the centreline velocities. Default
    /// `[0.02, 0.05]`.
    pub ghia_tolerance: Option<[f64; 2]>,
    /// Whether the Ghia deviation is a pass/fail check (it is always measured). Default true.
    pub check_ghia: Option<bool>,
    /// How the walls' no-penetration condition enters the projection: `"continuation"`
    /// (default) or `"reflection"` (the older condition, kept for comparison), see
    /// [`WallCondition`].
    #[serde(default)]
    pub wall_condition: WallCondition,
    /// How the walls are represented: `"dummy"` (default: fixed dummy particles, Adami et al.
    /// 2012) or `"ghost"` (mirror ghosts of the fluid, Szewc et al. 2012, the paper's walls);
    /// see [`WallModel`](sph_integrators::WallModel). With ghosts `wall_condition` and
    /// `wall_layers` do not apply.
    #[serde(default)]
    pub wall_model: CavityWallModel,
}

/// The cavity's wall model as a scene names it (`[cavity] wall_model`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CavityWallModel {
    /// Fixed dummy particles ([`WallModel::DummyParticles`](sph_integrators::WallModel)).
    #[default]
    Dummy,
    /// Mirror ghosts ([`WallModel::MirrorGhosts`](sph_integrators::WallModel)).
    Ghost,
}

fn one() -> f64 {
    1.0
}

/// Particle shifting as declared in a scene (the spacing is the scene's `dx`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShiftingSpec {
    /// Lind et al.'s `A` (they use 2).
    pub coefficient: f64,
    /// The speed scaling the shift: `"local"` (`|u_i|`), `"max"` (the largest fluid speed,
    /// Sun et al. 2017) or `"tension"` (the largest where the particle's pressure is negative,
    /// its own elsewhere; only with a free surface, which fixes the pressure's level). Default:
    /// `"max"` for `flow` scenes without a free surface, `"tension"` for `flow` and `dam_break`
    /// scenes with one, `"local"` for the paper's cases (see [`Scene::sim_config`]).
    pub velocity: Option<ShiftScale>,
    /// How the velocity follows the shift: `"taylor"` (Xu et al. 2009's correction; the default
    /// of the paper's cases), `"limited"` (that correction kept within the range of the
    /// neighbours' velocities; the default of `flow` and `dam_break` scenes) or `"none"`.
    pub velocity_correction: Option<ShiftVelocity>,
}

/// `[effects] viscosity = { nu = ..., operator = ... }`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViscositySpec {
    /// Kinematic viscosity `ν`.
    pub nu: f64,
    /// The discrete Laplacian: `"corrected"` (Morris' with its leading error removed in the
    /// bulk; the default of `flow` and `dam_break` scenes) or `"morris"` (the paper's; the
    /// default of the paper's cases).
    pub operator: Option<ViscousOperator>,
}

/// Explicit effects a scene declares (`[effects]`). Absent ones are not computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectsSpec {
    /// Laminar viscosity `{ nu = ... }` (the cavity derives it from `reynolds` instead).
    pub viscosity: Option<ViscositySpec>,
    /// Body-force acceleration `[gx, gy, gz]`.
    pub gravity: Option<[f64; 3]>,
    /// Particle shifting `{ coefficient = 2.0 }`.
    pub shifting: Option<ShiftingSpec>,
    /// Particle-scale dissipation `{ speed = C }`: hyperviscosity with `ν₄ = C h³`
    /// ([`Hyperviscosity`]).
    pub hyperviscosity: Option<Hyperviscosity>,
}

/// DG Hessian choice in a scene (`"eq25"` or `"quadratic_fit"`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DgHessianChoice {
    /// Paper Eq. 25 with coefficient d + 2.
    #[default]
    Eq25,
    /// Least-squares Hessian, exact for quadratic fields.
    QuadraticFit,
}

impl From<DgHessianChoice> for HessianForm {
    fn from(c: DgHessianChoice) -> Self {
        match c {
            DgHessianChoice::Eq25 => HessianForm::Eq25,
            DgHessianChoice::QuadraticFit => HessianForm::QuadraticFit,
        }
    }
}

/// `[time_step]`: the automatic time step ([`AutoTimeStep`]): each step's `Δt` is the largest
/// the advective, viscous and body-force limits allow, at most the scene's `dt`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeStepSpec {
    /// Choose `Δt` each step. Default: on for `flow` and `dam_break`, off for the paper's cases
    /// (which keep their fixed `dt`).
    pub auto: Option<bool>,
    /// `C_u` of `Δt ≤ C_u h / max|u|`, in (0, 1]. Default 0.2.
    pub advective: Option<f64>,
    /// `C_ν` of `Δt ≤ C_ν h² / ν`, in (0, 1]. Default 0.125.
    pub viscous: Option<f64>,
    /// `C_f` of `Δt ≤ C_f √(h / |g|)`, in (0, 1]. Default 0.25.
    pub force: Option<f64>,
}

/// Overrides applied by the quick validation preset.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuickOverrides {
    /// Coarser spacing.
    pub dx: Option<f64>,
    /// Shorter run.
    pub t_end: Option<f64>,
    /// Another time step (with a coarser `dx`).
    pub dt: Option<f64>,
    /// Cavity: whether the Ghia deviation is checked (a short quick run is not yet steady).
    pub check_ghia: Option<bool>,
}

/// A scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Case to run. Default `flow`.
    #[serde(default)]
    pub case: CaseKind,
    /// Spatial dimension (2 or 3; must suit the case).
    pub dim: usize,
    /// Initial particle spacing.
    pub dx: f64,
    /// `h / dx`. Default 1.3 (the paper's).
    #[serde(default = "default_h_over_dx")]
    pub h_over_dx: f64,
    /// Kernel. Default quintic spline.
    #[serde(default = "default_kernel")]
    pub kernel: KernelKind,
    /// Fixed time step.
    pub dt: f64,
    /// End time. Runs end on the last full step at or before it; a remaining fraction is taken
    /// as a separate short step and flagged in the records.
    pub t_end: f64,
    /// Schemes to run (each from the same initial state).
    pub schemes: Vec<SchemeKind>,
    /// Reference density `ρ₀`. Default 1.
    pub rho0: Option<f64>,
    /// Free surface; absent means none.
    pub free_surface: Option<FreeSurfaceSpec>,
    /// The projection's discrete operators (defaults depend on the case).
    #[serde(default)]
    pub pressure: PressureSpec,
    /// Linear solver. Default BiCGSTAB + AMG.
    #[serde(default)]
    pub solver: SolverKind,
    /// Relative residual tolerance of the pressure solve. Default 1e-9.
    pub solver_tolerance: Option<f64>,
    /// Start each pressure solve from the previous step's pressure (`true`, the default) or
    /// from zero.
    #[serde(default = "default_true")]
    pub solver_warm_start: bool,
    /// Hessian of the DG equation. Default `eq25`.
    #[serde(default)]
    pub dg_hessian: DgHessianChoice,
    /// Renumber the fluid particles in cell order every this many steps (`0`: never). Default
    /// `DEFAULT_REORDER_EVERY` (20). See [`SimConfig::reorder_every`].
    pub reorder_every: Option<usize>,
    /// Lid-driven cavity parameters (required by, and only allowed for, `lid_driven_cavity`).
    pub cavity: Option<CavitySpec>,
    /// How the walls' no-penetration condition enters the projection (block-posed walls;
    /// the cavity has its own key). Default `continuation`.
    pub wall_condition: Option<WallCondition>,
    /// Explicit effects. Default: none.
    #[serde(default)]
    pub effects: EffectsSpec,
    /// The periodic box (`flow`, `dam_break`).
    pub domain: Option<DomainSpec>,
    /// Fluid blocks (`flow`, `dam_break`).
    #[serde(default)]
    pub fluid: Vec<FluidBlock>,
    /// Wall blocks (`flow`, `dam_break`).
    #[serde(default)]
    pub wall: Vec<WallBlock>,
    /// What a run records and writes.
    #[serde(default)]
    pub output: OutputSpec,
    /// Allocation bounds and the blow-up limit.
    #[serde(default)]
    pub limits: LimitsSpec,
    /// How the initial state is prepared (settling).
    #[serde(default)]
    pub start: StartSpec,
    /// The automatic time step (`dt` its upper bound).
    #[serde(default)]
    pub time_step: TimeStepSpec,
    /// A start-up channel flow measured against its series solution (`flow`).
    pub channel: Option<ChannelSpec>,
    /// Pass criteria on the run's results, declared before the run.
    #[serde(default)]
    pub check: Vec<CheckSpec>,
    /// Quick-preset overrides.
    pub quick: Option<QuickOverrides>,
}

fn default_h_over_dx() -> f64 {
    1.3
}

fn default_kernel() -> KernelKind {
    KernelKind::QuinticSpline
}

/// What a scene will allocate and run, estimated before anything is allocated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Fluid particles.
    pub fluid: f64,
    /// Wall particles.
    pub walls: f64,
    /// Probe points of the case's measurements.
    pub probes: f64,
    /// Neighbours per particle (with itself).
    pub neighbors: f64,
    /// Memory of one run in bytes.
    pub bytes: f64,
    /// Steps of one scheme.
    pub steps: f64,
}

impl Estimate {
    /// Fluid and wall particles.
    pub fn particles(&self) -> f64 {
        self.fluid + self.walls
    }
}

/// Density relaxation of `flow` and `dam_break` scenes when `[pressure]` does not say: the
/// fraction of each particle's packing error moved back per step, by displacements
/// (`DensityRelaxationForm::Position`). Chosen from the study in docs/hard-cases.md.
pub const FLOW_DENSITY_RELAXATION: f64 = 0.05;

/// Hyperviscosity of `flow` and `dam_break` scenes with a free surface when `[effects]
/// hyperviscosity` does not say: the speed `C` (`ν₄ = C h³`) as a fraction of the scene's speed
/// scale ([`Scene::speed_scale`]), acting where the pressure is positive
/// ([`HyperviscousRegion::PositivePressure`]). Chosen from the study in docs/hard-cases.md.
pub const FLOW_HYPERVISCOSITY: f64 = 0.2;

/// Steps between renumberings of the fluid particles in cell order when a scene does not say
/// (`reorder_every`). The order decays slowly (a cavity's neighbour search slows by a quarter over
/// thousands of steps); each renumbering costs about one neighbour search and a fresh AMG set-up.
pub const DEFAULT_REORDER_EVERY: usize = 20;

/// Fewest fluid particles a scene's geometry may hold (estimated before building).
const MIN_FLUID_ESTIMATE: f64 = 16.0;

/// Bytes per particle other than the neighbour lists and the matrix: positions, velocities,
/// scratch vectors and matrices of the schemes (≈ 60 f64 in 3D).
const BYTES_PER_PARTICLE: f64 = 600.0;
/// Bytes per neighbour pair: the list's `u32` index, the matrix value and the gauge's bordered
/// copy of both (4 + 8 + 4 + 8), plus the AMG's coarse levels and the per-chunk scratch.
const BYTES_PER_PAIR: f64 = 40.0;

fn default_true() -> bool {
    true
}

impl Scene {
    /// The paper's drop setup (Section 5) for `case` at spacing `dx` and step `dt`, run to
    /// `t_end`: quintic kernel, h = 1.3 dx, the default free-surface threshold of the dimension,
    /// all three schemes, Eq. 25 Hessian, default solver. Callers change what they study.
    pub fn paper_drop(case: CaseKind, dx: f64, dt: f64, t_end: f64) -> Self {
        Scene {
            case,
            dim: case.dim(),
            dx,
            h_over_dx: default_h_over_dx(),
            kernel: default_kernel(),
            dt,
            t_end,
            schemes: SchemeKind::ALL.to_vec(),
            rho0: None,
            free_surface: Some(FreeSurfaceSpec {
                div_r_threshold: Some(FreeSurface::default_for(case.dim()).div_r_threshold),
                scan: None,
                extrapolate: None,
                complete_band: None,
                measured_depth: None,
            }),
            pressure: PressureSpec::default(),
            solver: SolverKind::default(),
            solver_tolerance: None,
            reorder_every: None,
            solver_warm_start: true,
            dg_hessian: DgHessianChoice::default(),
            cavity: None,
            wall_condition: None,
            effects: EffectsSpec::default(),
            domain: None,
            fluid: Vec::new(),
            wall: Vec::new(),
            output: OutputSpec::default(),
            limits: LimitsSpec::default(),
            start: StartSpec::default(),
            time_step: TimeStepSpec::default(),
            channel: None,
            check: Vec::new(),
            quick: None,
        }
    }

    /// Reference density (default 1).
    pub fn rho0(&self) -> f64 {
        self.rho0.unwrap_or(1.0)
    }

    /// Smoothing length `h = h_over_dx · dx`.
    pub fn h(&self) -> f64 {
        self.h_over_dx * self.dx
    }

    /// Kernel support radius.
    pub fn support(&self) -> f64 {
        self.kernel.support_factor() * self.h()
    }

    /// Number of full steps and whether a shorter last step remains.
    pub fn steps(&self) -> (usize, Option<f64>) {
        let full = (self.t_end / self.dt + 1e-9).floor() as usize;
        let rest = self.t_end - full as f64 * self.dt;
        (full, (rest > 1e-9 * self.dt).then_some(rest))
    }

    /// The automatic time step, when the scene's steps are chosen automatically (`[time_step]`;
    /// by default for `flow` and `dam_break`); `None`: every step is `dt`.
    pub fn auto_time_step(&self) -> Option<AutoTimeStep> {
        let ts = &self.time_step;
        if !ts.auto.unwrap_or(self.case.uses_blocks()) {
            return None;
        }
        let d = AutoTimeStep::default();
        Some(AutoTimeStep {
            advective: ts.advective.unwrap_or(d.advective),
            viscous: ts.viscous.unwrap_or(d.viscous),
            force: ts.force.unwrap_or(d.force),
        })
    }

    /// The per-step diagnostics the scene's output asks for.
    pub fn diagnostics(&self) -> Diagnostics {
        Diagnostics {
            det_f: self.output.diagnostics.contains(&DiagnosticKind::DetF),
            div_u: self.output.diagnostics.contains(&DiagnosticKind::DivU),
        }
    }

    /// The numerical configuration of the scene (kernel, h, free surface, solver, DG Hessian,
    /// declared effects, diagnostics, periodic axes, limits). Cases add what they derive (e.g.
    /// the cavity's viscosity).
    pub fn sim_config(&self) -> SimConfig {
        let mut config = SimConfig::new(self.kernel, self.h());
        config.rho0 = self.rho0();
        let flow = self.case.uses_blocks();
        // A flow scene's operators follow its boundary (docs/physics.md, "The flow scenes'
        // numerics"): with a free surface the symmetric pair (energy-safe at impacts, its
        // pressure level fixed by p = 0 on the surface); without one (periodic, sealed or
        // walled) the pressure's level is arbitrary, and only the renormalised difference pair
        // does not depend on it — exact for linear fields, with nothing to impact.
        let closed_flow = flow && self.free_surface.is_none();
        let gradient = self.pressure.gradient.unwrap_or(if flow && !closed_flow {
            GradientChoice::Symmetric
        } else {
            GradientChoice::Difference
        });
        config.gradient = match gradient {
            GradientChoice::Difference => sph_operators::GradientForm::Difference,
            GradientChoice::Symmetric => sph_operators::GradientForm::Symmetric,
            GradientChoice::Adjoint => sph_operators::GradientForm::Adjoint,
        };
        config.renormalise = self
            .pressure
            .renormalise
            .unwrap_or(!flow || (closed_flow && gradient != GradientChoice::Symmetric));
        config.consistent_laplacian = self.pressure.consistent_laplacian.unwrap_or(false);
        // The symmetric gradient's projection is made consistent at any pressure level
        // (docs/physics.md, "The symmetric gradient at a pressure level").
        config.level_consistent = self.pressure.level_consistent.unwrap_or(
            config.gradient == sph_operators::GradientForm::Symmetric && !config.renormalise,
        );
        // Flow scenes divide the gradient's lattice factor out (docs/physics.md, "The gradient's
        // lattice factor"); the paper's renormalised gradient needs no factor.
        config.normalised_gradient = self
            .pressure
            .normalise_gradient
            .unwrap_or(flow && !config.renormalise);
        // Flow scenes put `p = 0` half a spacing outside the surface particles (Robin rows) where
        // their gradient allows it (docs/physics.md, "Where p = 0 is put").
        let robin_default = flow && symmetric_with_level_term(&config);
        // The band's rows are completed where the surface rows are Robin rows, by default
        // (docs/physics.md, "Completing the surface band's rows").
        config.free_surface = self.free_surface.map(|f| {
            let robin = f.extrapolate.unwrap_or(robin_default);
            FreeSurface {
                div_r_threshold: f
                    .div_r_threshold
                    .unwrap_or(FreeSurface::default_for(self.dim).div_r_threshold),
                scan: f.scan.unwrap_or(flow),
                zero_pressure_depth: if robin { 0.5 * self.dx } else { 0.0 },
                complete_band: f.complete_band.unwrap_or(robin),
                measured_depth: f.measured_depth.unwrap_or(robin),
            }
        });
        // Flow scenes relax their packing by displacements (docs/physics.md, "Density
        // relaxation"); the paper's cases keep the paper's projection.
        config.density_relaxation = self.pressure.density_relaxation.unwrap_or(if flow {
            FLOW_DENSITY_RELAXATION
        } else {
            0.0
        });
        config.density_relaxation_form = self.pressure.density_relaxation_form.unwrap_or(if flow {
            DensityRelaxationForm::Position
        } else {
            DensityRelaxationForm::Velocity
        });
        config.solver = self.solver;
        if let Some(tol) = self.solver_tolerance {
            config.solve.rel_tolerance = tol;
        }
        config.warm_start = self.solver_warm_start;
        config.reorder_every = self.reorder_every.unwrap_or(DEFAULT_REORDER_EVERY);
        config.dg_hessian = self.dg_hessian.into();
        config.effects = Effects {
            viscosity: self.effects.viscosity.map(|v| Viscosity {
                nu: v.nu,
                operator: v.operator.unwrap_or(if flow {
                    ViscousOperator::Corrected
                } else {
                    ViscousOperator::Morris
                }),
            }),
            gravity: self.effects.gravity,
            shifting: self.effects.shifting.map(|s| Shifting {
                coefficient: s.coefficient,
                // Scaled by each particle's own speed the shift does not act at a closed
                // flow's stagnation points and vortex centres, nor at the slow core of a fluid
                // in tension, whose particles then pair (docs/physics.md).
                scale: s.velocity.unwrap_or(if closed_flow {
                    ShiftScale::Max
                } else if flow {
                    ShiftScale::Tension
                } else {
                    ShiftScale::Local
                }),
                velocity_correction: s.velocity_correction.unwrap_or(if flow {
                    ShiftVelocity::Limited
                } else {
                    ShiftVelocity::Taylor
                }),
                spacing: self.dx,
            }),
            hyperviscosity: self.hyperviscosity(),
        };
        config.diagnostics = self.diagnostics();
        config.periodic = self.periodic_axes();
        config.limits = Limits {
            max_displacement: self.limits.max_displacement.unwrap_or(1.0),
        };
        config
    }

    /// What a run of this scene resolves its numerics to, as text: its [`SimConfig`] less how the
    /// linear systems are solved and what is recorded (keys [`Self::resume_differences`] lets
    /// differ), the automatic step with the viscosity its limit keeps, and the step's end rule
    /// ([`END_STEPS`](crate::run::END_STEPS)). A checkpoint records it and a run resumes only
    /// where this build resolves the same, so a default changed between builds cannot change the
    /// physics mid-run.
    pub fn resolved_numerics(&self) -> String {
        let mut c = self.sim_config();
        let plain = SimConfig::new(c.kernel, c.h);
        c.solver = plain.solver;
        c.solve = plain.solve;
        c.warm_start = plain.warm_start;
        c.reorder_every = plain.reorder_every;
        c.diagnostics = plain.diagnostics;
        let auto = self.auto_time_step();
        let limit = auto.map(|a| self.limit_viscosity(&a));
        format!(
            "{c:?}; time step {auto:?}, limit viscosity {limit:?}, end steps {}",
            crate::run::END_STEPS
        )
    }

    /// The periodic axes of `[domain]`, if any.
    pub fn periodic_axes(&self) -> Option<PeriodicAxes> {
        let d = self.domain.as_ref()?;
        if d.periodic.is_empty() {
            return None;
        }
        let mut axes = [false; 3];
        for a in &d.periodic {
            axes[axis_index(a)?] = true;
        }
        let corner = |v: &Option<Vec<f64>>| -> Option<[f64; 3]> {
            let v = v.as_ref()?;
            Some(std::array::from_fn(|k| v.get(k).copied().unwrap_or(0.0)))
        };
        Some(PeriodicAxes {
            lo: corner(&d.min)?,
            hi: corner(&d.max)?,
            axes,
        })
    }

    /// Parses and validates a scene (and its quick-preset variant); `name` is used in error
    /// messages.
    pub fn parse(name: &str, text: &str) -> Result<Self, CaseError> {
        let scene: Scene = toml::from_str(text).map_err(|e| CaseError::Parse {
            scene: name.to_string(),
            message: clip_lines(&e.to_string(), 160),
        })?;
        scene.validate(name)?;
        scene.snapshots_in_time(name)?;
        if scene.quick.is_some() {
            scene
                .quick()
                .validate(&format!("{name} (with its [quick] overrides)"))?;
        }
        Ok(scene)
    }

    /// A snapshot time after the scene's own `t_end` would never be written: an error in the
    /// scene as written (a run shortened by the quick preset or `--t-end` skips it).
    fn snapshots_in_time(&self, name: &str) -> Result<(), CaseError> {
        let late = |t: &&f64| **t > self.t_end * (1.0 + 1e-9);
        let found = [
            ("output.snapshots", self.output.snapshots.iter().find(late)),
            (
                "cavity.snapshots",
                self.cavity
                    .as_ref()
                    .and_then(|c| c.snapshots.iter().find(late)),
            ),
        ];
        match found.into_iter().find_map(|(k, t)| t.map(|t| (k, t))) {
            Some((field, t)) => Err(CaseError::Invalid {
                scene: name.to_string(),
                field: field.into(),
                message: format!(
                    "{t} is after t_end = {}: that snapshot would never be written",
                    self.t_end
                ),
            }),
            None => Ok(()),
        }
    }

    /// The scene with the quick-preset overrides applied.
    pub fn quick(&self) -> Scene {
        let mut s = self.clone();
        if let Some(q) = &self.quick {
            if let Some(dx) = q.dx {
                s.dx = dx;
            }
            if let Some(t) = q.t_end {
                s.t_end = t;
            }
            if let Some(dt) = q.dt {
                s.dt = dt;
            }
            if let (Some(c), Some(g)) = (s.cavity.as_mut(), q.check_ghia) {
                c.check_ghia = Some(g);
            }
        }
        s
    }

    /// What the scene would allocate and run (particle, probe and step counts, memory), from
    /// its geometry alone.
    pub fn estimate(&self) -> Estimate {
        let d = self.dim as i32;
        let dx = self.dx;
        let cells = |v: f64| v / dx.powi(d);
        let layers =
            |l: Option<usize>| l.map_or((self.support() / dx - 1e-9).ceil().max(1.0), |l| l as f64);
        let (fluid, walls, probes) = match self.case {
            CaseKind::EllipticalDrop | CaseKind::PrescribedEllipse => {
                (cells(std::f64::consts::PI * 0.7), 0.0, 0.0)
            }
            CaseKind::SpheroidDrop | CaseKind::PrescribedEllipsoid => {
                (cells(4.0 / 3.0 * std::f64::consts::PI * 0.49), 0.0, 0.0)
            }
            CaseKind::LidDrivenCavity => {
                let c = self.cavity.as_ref();
                let l = layers(c.and_then(|c| c.wall_layers));
                let n = 1.0 / dx;
                let probe = c.and_then(|c| c.probe_spacing).unwrap_or(dx);
                (
                    n.powi(d),
                    (n + 2.0 * l).powi(d) - n.powi(d),
                    (1.0 / probe).round().max(1.0).powi(d),
                )
            }
            CaseKind::Flow | CaseKind::DamBreak => {
                let fluid: f64 = self
                    .fluid
                    .iter()
                    .map(|b| cells(block_measure(b, self.dim)))
                    .sum();
                let walls: f64 = self
                    .wall
                    .iter()
                    .map(|w| {
                        let ext = |k: usize| {
                            w.max.get(k).copied().unwrap_or(0.0)
                                - w.min.get(k).copied().unwrap_or(0.0)
                        };
                        let inner: f64 = (0..self.dim).map(ext).product();
                        match w.kind {
                            WallKind::Solid => cells(inner),
                            WallKind::Container => {
                                let t = layers(w.layers) * dx;
                                let outer: f64 = (0..self.dim).map(|k| ext(k) + 2.0 * t).product();
                                cells(outer - inner)
                            }
                        }
                    })
                    .sum();
                (fluid, walls, 0.0)
            }
        };
        let support = self.support() / dx;
        let neighbors = if self.dim == 2 {
            std::f64::consts::PI * support * support
        } else {
            4.0 / 3.0 * std::f64::consts::PI * support.powi(3)
        };
        let n = fluid + walls;
        Estimate {
            fluid,
            walls,
            probes,
            neighbors,
            bytes: n * (BYTES_PER_PARTICLE + BYTES_PER_PAIR * neighbors) + probes * 100.0,
            steps: (self.t_end / self.step_bound().0).ceil(),
        }
    }

    /// The largest step the run can take and what sets it: `dt`, or with the automatic step
    /// the smaller of `dt` and the limits known before the run (viscous and body force; the
    /// advective one depends on the flow).
    pub fn step_bound(&self) -> (f64, Option<DtBound>) {
        match self.auto_time_step() {
            None => (self.dt, None),
            Some(a) => {
                let nu = self.limit_viscosity(&a);
                let g = self.effects.gravity.map_or(0.0, |g| {
                    g[..self.dim.min(3)]
                        .iter()
                        .map(|c| c * c)
                        .sum::<f64>()
                        .sqrt()
                });
                let (dt, b) = a.choose(self.dt, self.h(), 0.0, nu, g);
                (dt, Some(b))
            }
        }
    }

    /// The hyperviscosity the scene runs with: the declared one (none for `speed = 0`); else,
    /// in a flow scene with a free surface, `C =` [`FLOW_HYPERVISCOSITY`] × [`Self::speed_scale`]
    /// where the pressure is positive (docs/physics.md, "Particle-scale dissipation"); else none.
    pub fn hyperviscosity(&self) -> Option<Hyperviscosity> {
        match self.effects.hyperviscosity {
            Some(hv) => (hv.speed > 0.0).then_some(hv),
            None if self.case.uses_blocks() && self.free_surface.is_some() => {
                let speed = FLOW_HYPERVISCOSITY * self.speed_scale();
                (speed > 0.0).then_some(Hyperviscosity {
                    speed,
                    region: HyperviscousRegion::PositivePressure,
                })
            }
            None => None,
        }
    }

    /// The fluid's speed scale from the scene alone, `U = √(|g| H + U₀²)`: `H` the extent of the
    /// fluid blocks (their bounding boxes) along gravity, the height its potential energy can turn
    /// into speed (`√(gH)` for water at rest in a tank, `√(2ga)` for a dam-break column of
    /// height `2a`, a drop's fall to its pool included), and `U₀` a bound on the initial speeds
    /// over the blocks' bounding boxes (constant velocity, velocity gradient, rigid rotation,
    /// Taylor–Green amplitude). 0 for fluid at rest without gravity.
    pub fn speed_scale(&self) -> f64 {
        // (Total before validation: any dimension, vectors of any length.)
        let d = self.dim.min(3);
        let norm = |v: &[f64]| v.iter().take(d).map(|x| x * x).sum::<f64>().sqrt();
        let g = self.effects.gravity.map_or([0.0; 3], |g| g);
        let gn = norm(&g);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut u0: f64 = 0.0;
        for b in &self.fluid {
            let (blo, bhi) = block_bounds(b, d);
            // The box's corners: their extremes along g and their distances from a centre.
            let corners = (0..1usize << d).map(|m| {
                let mut c = [0.0; 3];
                for k in 0..d {
                    c[k] = if m >> k & 1 == 1 { bhi[k] } else { blo[k] };
                }
                c
            });
            let centre: Vec<f64> = (0..d).map(|k| 0.5 * (blo[k] + bhi[k])).collect();
            let reach = |c: &[f64]| {
                corners
                    .clone()
                    .map(|x| {
                        let r: Vec<f64> = (0..d)
                            .map(|k| x[k] - c.get(k).copied().unwrap_or(0.0))
                            .collect();
                        norm(&r)
                    })
                    .fold(0.0, f64::max)
            };
            if gn > 0.0 {
                for x in corners.clone() {
                    let along = (0..d).map(|k| x[k] * g[k]).sum::<f64>() / gn;
                    (lo, hi) = (lo.min(along), hi.max(along));
                }
            }
            let mut u = b.velocity.as_deref().map_or(0.0, norm);
            if let Some(m) = &b.velocity_gradient {
                // |G (x − c)| is convex in x: its largest value on the box is at a corner.
                let at = |x: [f64; 3]| {
                    let r: Vec<f64> = (0..d).map(|k| x[k] - centre[k]).collect();
                    let gr: Vec<f64> = (0..d)
                        .map(|i| {
                            let row = m.get(i).map_or(&[][..], |r| r.as_slice());
                            (0..d)
                                .map(|j| row.get(j).copied().unwrap_or(0.0) * r[j])
                                .sum::<f64>()
                        })
                        .collect();
                    norm(&gr)
                };
                u += corners.clone().map(at).fold(0.0, f64::max);
            }
            if let Some(f) = &b.velocity_field {
                u += match f.kind {
                    crate::blocks::FieldKind::RigidRotation => {
                        let c = f.center.clone().unwrap_or(centre.clone());
                        f.omega.unwrap_or(0.0).abs() * reach(&c)
                    }
                    crate::blocks::FieldKind::TaylorGreen => f.amplitude.unwrap_or(1.0).abs(),
                };
            }
            u0 = u0.max(u);
        }
        let height = if hi > lo { hi - lo } else { 0.0 };
        (gn * height + u0 * u0).sqrt()
    }

    /// The viscosity whose explicit limit `Δt ≤ C_ν h²/ν` the automatic step `a` keeps: the
    /// scene's `ν`, plus the hyperviscous term's limit `Δt ≤ K/(ν₄ λ²)` written as the viscosity
    /// `C_ν h² ν₄ λ² / K` with that limit (`K` =
    /// [`HYPERVISCOUS_STEP`](sph_integrators::HYPERVISCOUS_STEP)) (`λ` the Gershgorin bound of Morris' Laplacian on the
    /// scene's lattice, [`Hyperviscosity::rate`](sph_integrators::Hyperviscosity::rate)).
    pub fn limit_viscosity(&self, a: &AutoTimeStep) -> f64 {
        let nu = self.effects.viscosity.map_or(0.0, |v| v.nu);
        let Some(hv) = self.hyperviscosity() else {
            return nu;
        };
        let h = self.h();
        let rate = if self.dim == 2 {
            let k = self.kernel.build::<sph_core::D2>(h);
            hv.rate::<sph_core::D2, _>(&k, self.dx.powi(2))
        } else {
            let k = self.kernel.build::<sph_core::D3>(h);
            hv.rate::<sph_core::D3, _>(&k, self.dx.powi(3))
        };
        nu + a.viscous * h * h * rate / sph_integrators::HYPERVISCOUS_STEP
    }

    /// Whether `self` may continue a run written under `written` (its checkpoint's scene): the
    /// same physics, with only these keys free to differ — when it ends (`t_end`), which schemes
    /// the command runs, how the (same) linear systems are solved and numbered (`solver`,
    /// `solver_tolerance`, `solver_warm_start`, `reorder_every`) and what is recorded and
    /// checked (`output`, `check`, the cavity's `snapshots`, `sample_every`, `ghia_tolerance`,
    /// `check_ghia`, the `quick` table). Returns the keys that differ otherwise.
    pub fn resume_differences(&self, written: &Scene) -> Vec<String> {
        let normalise = |s: &Scene| {
            let mut s = s.clone();
            s.t_end = 0.0;
            s.schemes.clear();
            s.solver = SolverKind::default();
            s.solver_tolerance = None;
            s.solver_warm_start = true;
            s.reorder_every = None;
            s.output = OutputSpec::default();
            s.check.clear();
            s.quick = None;
            if let Some(c) = s.cavity.as_mut() {
                c.snapshots.clear();
                c.sample_every = None;
                c.ghia_tolerance = None;
                c.check_ghia = None;
            }
            s
        };
        let (a, b) = (normalise(self), normalise(written));
        if a == b {
            return Vec::new();
        }
        let table = |s: &Scene| match toml::Value::try_from(s) {
            Ok(toml::Value::Table(t)) => t,
            _ => toml::map::Map::new(),
        };
        let (ta, tb) = (table(&a), table(&b));
        let mut keys: Vec<String> = ta
            .keys()
            .chain(tb.keys())
            .filter(|k| ta.get(*k) != tb.get(*k))
            .cloned()
            .collect();
        keys.sort();
        keys.dedup();
        if keys.is_empty() {
            keys.push("(a value that TOML cannot show)".into());
        }
        keys
    }

    /// Range and consistency checks; errors name the key.
    pub fn validate(&self, name: &str) -> Result<(), CaseError> {
        Validator { scene: self, name }.run()
    }
}

/// Magnitudes allowed for `rho0`, `|g|` and initial speeds (zero aside): far from the `f64`
/// limits that the pressure solver's squared norms reach (about 1e±308).
pub const SCALE_RANGE: (f64, f64) = (1e-100, 1e100);

/// The bounding box of a (validated) fluid block: lower and upper corners (unused axes 0).
fn block_bounds(b: &FluidBlock, dim: usize) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([0.0; 3], [0.0; 3]);
    let at = |v: &Option<Vec<f64>>, k: usize| v.as_ref().and_then(|v| v.get(k)).copied();
    for k in 0..dim {
        let (l, h) = match b.shape {
            FluidShape::Box => (at(&b.min, k), at(&b.max, k)),
            FluidShape::Ellipse | FluidShape::Ellipsoid => {
                let (c, a) = (at(&b.center, k), at(&b.semi_axes, k));
                (c.zip(a).map(|(c, a)| c - a), c.zip(a).map(|(c, a)| c + a))
            }
            FluidShape::Circle | FluidShape::Sphere => {
                let (c, r) = (at(&b.center, k), b.radius);
                (c.zip(r).map(|(c, r)| c - r), c.zip(r).map(|(c, r)| c + r))
            }
            FluidShape::Polygon => {
                let v = b.vertices.as_deref().unwrap_or_default();
                let xs = v.iter().filter_map(|p| p.get(k).copied());
                (xs.clone().reduce(f64::min), xs.reduce(f64::max))
            }
        };
        lo[k] = l.unwrap_or(0.0);
        hi[k] = h.unwrap_or(0.0);
    }
    (lo, hi)
}

/// Area (2D) or volume (3D) of a fluid block, for estimates (0 for an invalid block).
fn block_measure(b: &FluidBlock, dim: usize) -> f64 {
    let pi = std::f64::consts::PI;
    let v = |o: &Option<Vec<f64>>| o.clone().unwrap_or_default();
    match b.shape {
        FluidShape::Box => {
            let (lo, hi) = (v(&b.min), v(&b.max));
            (0..dim)
                .map(|k| hi.get(k).unwrap_or(&0.0) - lo.get(k).unwrap_or(&0.0))
                .product::<f64>()
                .max(0.0)
        }
        FluidShape::Ellipse | FluidShape::Ellipsoid => {
            let s: f64 = v(&b.semi_axes).iter().take(dim).product();
            if dim == 2 { pi * s } else { 4.0 / 3.0 * pi * s }
        }
        FluidShape::Circle | FluidShape::Sphere => {
            let r = b.radius.unwrap_or(0.0);
            if dim == 2 {
                pi * r * r
            } else {
                4.0 / 3.0 * pi * r.powi(3)
            }
        }
        FluidShape::Polygon => {
            let p = b.vertices.clone().unwrap_or_default();
            let mut twice = 0.0;
            for k in 0..p.len() {
                let (a, c) = (p[k], p[(k + 1) % p.len()]);
                twice += a[0] * c[1] - a[1] * c[0];
            }
            0.5 * twice.abs()
        }
    }
}

/// The checks of [`Scene::validate`], one method per table.
struct Validator<'a> {
    scene: &'a Scene,
    name: &'a str,
}

type Check = Result<(), CaseError>;

fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

/// Whether the pressure gradient is the symmetric one, not renormalised, with its level term in
/// the pressure equation: the combination the Robin surface rows need besides the renormalised
/// difference gradient (and get by default in flow scenes).
fn symmetric_with_level_term(c: &SimConfig) -> bool {
    !c.renormalise && c.gradient == sph_operators::GradientForm::Symmetric && c.level_consistent
}

impl Validator<'_> {
    fn bad(&self, field: impl Into<String>, message: impl Into<String>) -> Check {
        Err(CaseError::Invalid {
            scene: self.name.to_string(),
            field: field.into(),
            message: message.into(),
        })
    }

    /// `v` has `dim` finite entries.
    fn vector(&self, field: &str, v: &[f64]) -> Check {
        let d = self.scene.dim;
        if v.len() != d {
            return self.bad(
                field,
                format!("must have {d} entries (dim = {d}), got {}", v.len()),
            );
        }
        if v.iter().any(|x| !x.is_finite()) {
            return self.bad(field, "must be finite");
        }
        Ok(())
    }

    /// `x` lies on a multiple of `dx` (a face of the staggered lattice's cells).
    fn on_lattice(&self, field: &str, v: &[f64]) -> Check {
        let dx = self.scene.dx;
        for x in v {
            let k = x / dx;
            if (k - k.round()).abs() > 1e-6 * k.abs().max(1.0) {
                return self.bad(
                    field,
                    format!(
                        "must lie on multiples of dx = {dx} (the particle lattice), got {x} \
                         ({x}/dx = {k})"
                    ),
                );
            }
        }
        Ok(())
    }

    fn run(&self) -> Check {
        let s = self.scene;
        if !(s.dim == 2 || s.dim == 3) {
            return self.bad("dim", format!("must be 2 or 3, got {}", s.dim));
        }
        if !s.case.supports_dim(s.dim) {
            return self.bad(
                "dim",
                format!(
                    "is {}, but {} is a {}D case",
                    s.dim,
                    s.case.name(),
                    s.case.dim()
                ),
            );
        }
        if !positive(s.dx) {
            return self.bad("dx", format!("must be a positive number, got {}", s.dx));
        }
        if !(s.h_over_dx.is_finite() && (1.0..=3.0).contains(&s.h_over_dx)) {
            return self.bad(
                "h_over_dx",
                format!("must be in [1, 3], got {}", s.h_over_dx),
            );
        }
        if !positive(s.dt) {
            return self.bad("dt", format!("must be a positive number, got {}", s.dt));
        }
        for (key, value) in [
            ("advective", s.time_step.advective),
            ("viscous", s.time_step.viscous),
            ("force", s.time_step.force),
        ] {
            if let Some(c) = value
                && !(c.is_finite() && c > 0.0 && c <= 1.0)
            {
                return self.bad(
                    format!("time_step.{key}"),
                    format!("must be in (0, 1], got {c}"),
                );
            }
        }
        if let Some(c) = &s.channel {
            if s.case != CaseKind::Flow {
                return self.bad("channel", "applies to `flow` scenes only");
            }
            if !positive(c.height) {
                return self.bad(
                    "channel.height",
                    format!("must be a positive number, got {}", c.height),
                );
            }
            if !c.bottom.unwrap_or(0.0).is_finite() {
                return self.bad("channel.bottom", "must be a finite number");
            }
            if !s.effects.viscosity.is_some_and(|v| v.nu > 0.0) {
                return self.bad(
                    "channel",
                    "a channel flow needs [effects] viscosity = { nu = ... } > 0",
                );
            }
            match c.kind {
                ChannelKind::Poiseuille => {
                    if !s.effects.gravity.is_some_and(|g| g[0] != 0.0) {
                        return self.bad(
                            "channel",
                            "a Poiseuille flow is driven by [effects] gravity along x (nonzero x \
                             component)",
                        );
                    }
                }
                ChannelKind::Couette => {
                    if !c.wall_speed.is_some_and(|u| u.is_finite() && u != 0.0) {
                        return self.bad(
                            "channel.wall_speed",
                            "a Couette flow needs the upper plate's speed (nonzero)",
                        );
                    }
                }
            }
        }
        if !positive(s.t_end) {
            return self.bad(
                "t_end",
                format!("must be a positive number, got {}", s.t_end),
            );
        }
        if s.schemes.is_empty() {
            return self.bad("schemes", "must name at least one scheme");
        }
        let mut seen = s.schemes.clone();
        seen.sort_by_key(|k| k.name());
        seen.dedup();
        if seen.len() != s.schemes.len() {
            return self.bad("schemes", "names a scheme twice");
        }
        if s.rho0.is_some_and(|r| !positive(r)) {
            return self.bad("rho0", "must be a positive number");
        }
        self.scales()?;
        if let Some(th) = s.free_surface.and_then(|f| f.div_r_threshold) {
            let d = s.dim as f64;
            if !(th.is_finite() && th > 0.0 && th < d) {
                return self.bad(
                    "free_surface.div_r_threshold",
                    format!("must be in (0, {d}), got {th}"),
                );
            }
        }
        if let Some(c) = s.start.settle_damping
            && !(c.is_finite() && c > 0.0 && c <= 1.0)
        {
            return self.bad(
                "start.settle_damping",
                format!("must be in (0, 1], got {c}"),
            );
        }
        if let Some(a) = s.pressure.density_relaxation
            && !(0.0..=1.0).contains(&a)
        {
            return self.bad(
                "pressure.density_relaxation",
                format!("must be in [0, 1] (a fraction of the density error per step), got {a}"),
            );
        }
        if s.pressure.density_relaxation_form.is_some() && s.sim_config().density_relaxation == 0.0
        {
            return self.bad(
                "pressure.density_relaxation_form",
                "needs pressure.density_relaxation > 0 (without it nothing is relaxed)",
            );
        }
        let c = s.sim_config();
        if c.consistent_laplacian && !c.renormalise {
            return self.bad(
                "pressure.consistent_laplacian",
                "needs renormalisation (pressure.renormalise = true)",
            );
        }
        if c.level_consistent
            && (c.gradient != sph_operators::GradientForm::Symmetric || c.renormalise)
        {
            return self.bad(
                "pressure.level_consistent",
                "completes the equation for the symmetric gradient without renormalisation \
                 (pressure.gradient = \"symmetric\", pressure.renormalise = false); the other \
                 gradients are exact for a constant pressure and need no level term",
            );
        }
        if c.normalised_gradient && c.renormalise {
            return self.bad(
                "pressure.normalise_gradient",
                "needs a gradient without renormalisation (pressure.renormalise = false): the \
                 renormalised gradient is exact for linear fields already",
            );
        }
        if c.gradient == sph_operators::GradientForm::Adjoint && !c.renormalise {
            return self.bad(
                "pressure.gradient",
                "\"adjoint\" is the negative adjoint of the renormalised divergence: it needs \
                 pressure.renormalise = true (without it, it is \"symmetric\")",
            );
        }
        let renormalised_difference =
            c.renormalise && c.gradient == sph_operators::GradientForm::Difference;
        let symmetric_with_level = symmetric_with_level_term(&c);
        if c.free_surface.is_some_and(|f| f.zero_pressure_depth > 0.0)
            && !(renormalised_difference || symmetric_with_level)
        {
            return self.bad(
                "free_surface.extrapolate",
                "needs the renormalised difference gradient (pressure.gradient = \"difference\", \
                 pressure.renormalise = true) or the symmetric gradient with its level term \
                 (pressure.level_consistent = true): without the level term the symmetric \
                 gradient's Robin rows add energy at impacts (docs/hard-cases.md, \"Flow \
                 numerics\")",
            );
        }
        if s.free_surface.and_then(|f| f.measured_depth) == Some(true)
            && !c.free_surface.is_some_and(|f| f.zero_pressure_depth > 0.0)
        {
            return self.bad(
                "free_surface.measured_depth",
                "places the Robin rows' p = 0: it needs them (free_surface.extrapolate = true)",
            );
        }
        if s.solver_tolerance
            .is_some_and(|t| !(t.is_finite() && t > 0.0 && t < 1.0))
        {
            return self.bad("solver_tolerance", "must be in (0, 1)");
        }
        self.effects()?;
        self.cavity()?;
        self.blocks()?;
        self.output()?;
        self.limits()?;
        self.checks()?;
        self.quick()?;
        self.budget()
    }

    fn effects(&self) -> Check {
        let s = self.scene;
        if let Some(v) = s.effects.viscosity
            && !(v.nu.is_finite() && v.nu >= 0.0)
        {
            return self.bad("effects.viscosity.nu", format!("must be ≥ 0, got {}", v.nu));
        }
        if let Some(hv) = s.effects.hyperviscosity
            && !(hv.speed.is_finite() && hv.speed >= 0.0)
        {
            return self.bad(
                "effects.hyperviscosity.speed",
                format!("must be ≥ 0 (0: none), got {}", hv.speed),
            );
        }
        if let Some(hv) = s.effects.hyperviscosity
            && hv.region == HyperviscousRegion::PositivePressure
            && s.free_surface.is_none()
        {
            return self.bad(
                "effects.hyperviscosity.region",
                "\"positive_pressure\" needs a free surface to fix the pressure's level",
            );
        }
        if let Some(g) = s.effects.gravity
            && g.iter().any(|v| !v.is_finite())
        {
            return self.bad("effects.gravity", "must be finite");
        }
        if let Some(sh) = s.effects.shifting
            && !positive(sh.coefficient)
        {
            return self.bad("effects.shifting.coefficient", "must be positive");
        }
        if let Some(sh) = s.effects.shifting
            && sh.velocity == Some(ShiftScale::Tension)
            && s.free_surface.is_none()
        {
            return self.bad(
                "effects.shifting.velocity",
                "\"tension\" reads the sign of the pressure, whose level only a free surface \
                 fixes: it needs a [free_surface] section",
            );
        }
        Ok(())
    }

    fn cavity(&self) -> Check {
        let s = self.scene;
        let cavity = s.case == CaseKind::LidDrivenCavity;
        match (&s.cavity, cavity) {
            (None, true) => self.bad("cavity", "section is required by lid_driven_cavity"),
            (Some(_), false) => self.bad(
                "cavity",
                format!(
                    "section is only valid for lid_driven_cavity, not {}",
                    s.case.name()
                ),
            ),
            (Some(c), true) => {
                if !positive(c.reynolds) {
                    return self.bad(
                        "cavity.reynolds",
                        format!("must be positive, got {}", c.reynolds),
                    );
                }
                if !c.lid_speed.is_finite() || c.lid_speed == 0.0 {
                    return self.bad(
                        "cavity.lid_speed",
                        format!("must be finite and non-zero, got {}", c.lid_speed),
                    );
                }
                if c.wall_layers.is_some_and(|l| !(1..=10).contains(&l)) {
                    return self.bad("cavity.wall_layers", "must be in 1..=10");
                }
                if c.probe_spacing.is_some_and(|v| !positive(v) || v > 0.5) {
                    return self.bad("cavity.probe_spacing", "must be in (0, 0.5]");
                }
                if c.snapshots.iter().any(|t| !(t.is_finite() && *t >= 0.0)) {
                    return self.bad("cavity.snapshots", "must be non-negative times");
                }
                if c.sample_every == Some(0) {
                    return self.bad("cavity.sample_every", "must be at least 1");
                }
                if c.wall_model == CavityWallModel::Ghost {
                    if s.effects.gravity.is_some() {
                        // Measured: fluid at rest falls at 0.93 gΔt per step (test
                        // `ghost_walls_do_not_hold_fluid_at_rest_under_gravity`).
                        return self.bad(
                            "cavity.wall_model",
                            "mirror ghosts do not hold a fluid at rest under gravity (their \
                             reflected normal velocity and hydrostatic pressure count the wall \
                             twice); use the dummy walls with [effects] gravity",
                        );
                    }
                    if c.wall_condition != WallCondition::Continuation || c.wall_layers.is_some() {
                        return self.bad(
                            "cavity.wall_model",
                            "mirror ghosts take neither wall_condition nor wall_layers",
                        );
                    }
                }
                if c.ghia_tolerance
                    .is_some_and(|[a, b]| !(positive(a) && positive(b)))
                {
                    return self.bad("cavity.ghia_tolerance", "must be two positive numbers");
                }
                let cells = 1.0 / s.dx;
                if (cells - cells.round()).abs() > 1e-6 * cells {
                    return self.bad(
                        "dx",
                        format!("must divide the unit cavity, got {} (1/dx = {cells})", s.dx),
                    );
                }
                if s.free_surface.is_some() {
                    return self.bad("free_surface", "a closed cavity has no free surface");
                }
                if s.effects.viscosity.is_some() {
                    return self.bad("effects.viscosity", "is set by cavity.reynolds in a cavity");
                }
                if s.wall_condition.is_some() {
                    return self.bad("wall_condition", "a cavity sets it in its [cavity] table");
                }
                Ok(())
            }
            (None, false) => Ok(()),
        }
    }

    /// The magnitudes that enter the pressure equation: `ρ₀`, `|g|` and the initial speeds
    /// must lie within [`SCALE_RANGE`] (and `ρ₀ (|g| L + U²)`, the pressure scale, within its
    /// upper end), or the solver's squared norms overflow or underflow at step 0 — reported
    /// there as a broken-down solve. Each out-of-range value is named with its key.
    fn scales(&self) -> Check {
        let s = self.scene;
        let (lo, hi) = SCALE_RANGE;
        let outside = |v: f64| v != 0.0 && !(lo..=hi).contains(&v.abs());
        let advice = "choose units in which it is moderate (SI for water: 1000 kg/m³, 9.81 m/s²)";
        let rho = s.rho0();
        if outside(rho) {
            return self.bad(
                "rho0",
                format!("= {rho:e} is outside [{lo:e}, {hi:e}]; {advice}"),
            );
        }
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let g = s.effects.gravity.map_or(0.0, |g| norm(&g));
        if g > hi {
            return self.bad(
                "effects.gravity",
                format!("has magnitude {g:e}, above {hi:e}; {advice}"),
            );
        }
        let mut speeds: Vec<(String, f64)> = Vec::new();
        for (i, b) in s.fluid.iter().enumerate() {
            if let Some(v) = &b.velocity {
                speeds.push((format!("fluid[{i}].velocity"), norm(v)));
            }
            if let Some(f) = &b.velocity_field {
                let (blo, bhi) = block_bounds(b, s.dim);
                let size = (0..s.dim).map(|k| bhi[k] - blo[k]).fold(0.0, f64::max);
                speeds.push((
                    format!("fluid[{i}].velocity_field"),
                    f.amplitude.unwrap_or(1.0).abs() + f.omega.unwrap_or(0.0).abs() * size,
                ));
            }
        }
        for (i, w) in s.wall.iter().enumerate() {
            if let Some(v) = &w.velocity {
                speeds.push((format!("wall[{i}].velocity"), norm(v)));
            }
            for (f, v) in &w.face_velocity {
                speeds.push((format!("wall[{i}].face_velocity.{f}"), norm(v)));
            }
        }
        if let Some(c) = &s.cavity {
            speeds.push(("cavity.lid_speed".into(), c.lid_speed.abs()));
        }
        if let Some((key, u)) = speeds.iter().find(|(_, u)| *u > hi) {
            return self.bad(
                key.clone(),
                format!("is a speed of {u:e}, above {hi:e}; {advice}"),
            );
        }
        let u = speeds.iter().map(|(_, u)| *u).fold(0.0, f64::max);
        let extent = s
            .fluid
            .iter()
            .map(|b| {
                let (blo, bhi) = block_bounds(b, s.dim);
                (0..s.dim).map(|k| bhi[k] - blo[k]).fold(0.0, f64::max)
            })
            .fold(1.0, f64::max);
        let pressure = rho * (g * extent + u * u);
        if pressure > hi {
            return self.bad(
                "rho0",
                format!(
                    "= {rho:e} with |g| = {g:e} and speeds up to {u:e} gives pressures of about \
                     {pressure:e}, above {hi:e}; {advice}"
                ),
            );
        }
        Ok(())
    }

    fn blocks(&self) -> Check {
        let s = self.scene;
        if !s.case.uses_blocks() {
            for (key, present) in [
                ("fluid", !s.fluid.is_empty()),
                ("wall", !s.wall.is_empty()),
                ("domain", s.domain.is_some()),
                (
                    "wall_condition",
                    s.wall_condition.is_some() && s.case != CaseKind::LidDrivenCavity,
                ),
            ] {
                if present {
                    return self.bad(
                        key,
                        format!(
                            "is only valid for flow and dam_break scenes; {} builds its own \
                             geometry",
                            s.case.name()
                        ),
                    );
                }
            }
            return Ok(());
        }
        if s.fluid.is_empty() {
            return self.bad("fluid", "a flow needs at least one [[fluid]] block");
        }
        for (i, b) in s.fluid.iter().enumerate() {
            self.fluid_block(i, b)?;
        }
        for (i, w) in s.wall.iter().enumerate() {
            self.wall_block(i, w)?;
        }
        if s.wall_condition.is_some() && s.wall.is_empty() {
            return self.bad("wall_condition", "is set, but the scene has no [[wall]]");
        }
        self.fluid_in_containers()?;
        self.domain()
    }

    fn fluid_block(&self, i: usize, b: &FluidBlock) -> Check {
        let s = self.scene;
        let key = |k: &str| format!("fluid[{i}].{k}");
        let need = |k: &str, present: bool| -> Check {
            if present {
                Ok(())
            } else {
                self.bad(
                    key(k),
                    format!("is required for shape = {:?}", b.shape).to_lowercase(),
                )
            }
        };
        let unused = |k: &str, present: bool| -> Check {
            if present {
                self.bad(
                    key(k),
                    format!("does not apply to shape = {:?}", b.shape).to_lowercase(),
                )
            } else {
                Ok(())
            }
        };
        match b.shape {
            FluidShape::Box => {
                need("min", b.min.is_some())?;
                need("max", b.max.is_some())?;
                for k in ["center", "semi_axes", "radius", "vertices"] {
                    let present = match k {
                        "center" => b.center.is_some(),
                        "semi_axes" => b.semi_axes.is_some(),
                        "radius" => b.radius.is_some(),
                        _ => b.vertices.is_some(),
                    };
                    unused(k, present)?;
                }
                let (lo, hi) = (
                    b.min.as_ref().expect("checked"),
                    b.max.as_ref().expect("checked"),
                );
                self.vector(&key("min"), lo)?;
                self.vector(&key("max"), hi)?;
                if lo.iter().zip(hi).any(|(a, c)| a >= c) {
                    return self.bad(key("max"), "must exceed min along every axis");
                }
                if b.lattice == crate::blocks::LatticeKind::Staggered {
                    self.on_lattice(&key("min"), lo)?;
                    self.on_lattice(&key("max"), hi)?;
                }
            }
            FluidShape::Ellipse | FluidShape::Ellipsoid => {
                need("center", b.center.is_some())?;
                need("semi_axes", b.semi_axes.is_some())?;
                unused("min", b.min.is_some())?;
                unused("max", b.max.is_some())?;
                unused("radius", b.radius.is_some())?;
                unused("vertices", b.vertices.is_some())?;
                self.vector(&key("center"), b.center.as_ref().expect("checked"))?;
                let a = b.semi_axes.as_ref().expect("checked");
                self.vector(&key("semi_axes"), a)?;
                if a.iter().any(|v| !positive(*v)) {
                    return self.bad(key("semi_axes"), "must be positive");
                }
            }
            FluidShape::Circle | FluidShape::Sphere => {
                need("center", b.center.is_some())?;
                need("radius", b.radius.is_some())?;
                unused("min", b.min.is_some())?;
                unused("max", b.max.is_some())?;
                unused("semi_axes", b.semi_axes.is_some())?;
                unused("vertices", b.vertices.is_some())?;
                self.vector(&key("center"), b.center.as_ref().expect("checked"))?;
                if !b.radius.is_some_and(positive) {
                    return self.bad(key("radius"), "must be a positive number");
                }
            }
            FluidShape::Polygon => {
                if s.dim != 2 {
                    return self.bad(key("shape"), "polygon is a 2D shape");
                }
                need("vertices", b.vertices.is_some())?;
                unused("min", b.min.is_some())?;
                unused("max", b.max.is_some())?;
                unused("radius", b.radius.is_some())?;
                unused("semi_axes", b.semi_axes.is_some())?;
                let v = b.vertices.as_ref().expect("checked");
                if v.len() < 3 || v.iter().flatten().any(|x| !x.is_finite()) {
                    return self.bad(key("vertices"), "needs at least 3 finite vertices");
                }
                if block_measure(b, 2) <= 0.0 {
                    return self.bad(key("vertices"), "enclose no area");
                }
            }
        }
        if let Some(v) = &b.velocity {
            self.vector(&key("velocity"), v)?;
        }
        if let Some(g) = &b.velocity_gradient {
            if g.len() != s.dim {
                return self.bad(
                    key("velocity_gradient"),
                    format!("must have {} rows", s.dim),
                );
            }
            for row in g {
                self.vector(&key("velocity_gradient"), row)?;
            }
        }
        if let Some(f) = &b.velocity_field {
            use crate::blocks::FieldKind;
            match f.kind {
                FieldKind::RigidRotation => {
                    if !f.omega.is_some_and(|w| w.is_finite()) {
                        return self.bad(
                            key("velocity_field.omega"),
                            "is required (finite) for a rigid rotation",
                        );
                    }
                    if let Some(c) = &f.center {
                        self.vector(&key("velocity_field.center"), c)?;
                    }
                    if f.amplitude.is_some() || f.wavelength.is_some() {
                        return self.bad(
                            key("velocity_field"),
                            "amplitude and wavelength belong to taylor_green",
                        );
                    }
                }
                FieldKind::TaylorGreen => {
                    if f.amplitude.is_some_and(|a| !a.is_finite()) {
                        return self.bad(key("velocity_field.amplitude"), "must be finite");
                    }
                    if f.wavelength.is_some_and(|l| !positive(l)) {
                        return self.bad(key("velocity_field.wavelength"), "must be positive");
                    }
                    if f.omega.is_some() || f.center.is_some() {
                        return self.bad(
                            key("velocity_field"),
                            "omega and center belong to rigid_rotation",
                        );
                    }
                }
            }
        }
        if b.hydrostatic && s.effects.gravity.is_none() {
            return self.bad(key("hydrostatic"), "needs [effects] gravity");
        }
        if b.jitter
            .is_some_and(|j| !(j.is_finite() && (0.0..0.5).contains(&j)))
        {
            return self.bad(key("jitter"), "must be in [0, 0.5) (a fraction of dx)");
        }
        Ok(())
    }

    fn wall_block(&self, i: usize, w: &WallBlock) -> Check {
        let s = self.scene;
        let key = |k: &str| format!("wall[{i}].{k}");
        self.vector(&key("min"), &w.min)?;
        self.vector(&key("max"), &w.max)?;
        if w.min.iter().zip(&w.max).any(|(a, c)| a >= c) {
            return self.bad(key("max"), "must exceed min along every axis");
        }
        self.on_lattice(&key("min"), &w.min)?;
        self.on_lattice(&key("max"), &w.max)?;
        let face_ok = |f: &str| face_index(f).is_some_and(|(k, _)| k < s.dim);
        for f in &w.open {
            if !face_ok(f) {
                return self.bad(
                    key("open"),
                    format!(
                        "unknown face {f:?} (faces: -x +x -y +y{})",
                        if s.dim == 3 { " -z +z" } else { "" }
                    ),
                );
            }
        }
        if w.kind == WallKind::Solid && !w.open.is_empty() {
            return self.bad(key("open"), "a solid wall has no open faces");
        }
        if w.kind == WallKind::Container && w.open.len() >= 2 * s.dim {
            return self.bad(key("open"), "every face is open: the container has no wall");
        }
        if w.layers.is_some_and(|l| !(1..=10).contains(&l)) {
            return self.bad(key("layers"), "must be in 1..=10");
        }
        if let Some(v) = &w.velocity {
            self.vector(&key("velocity"), v)?;
        }
        for (f, v) in &w.face_velocity {
            if !face_ok(f) {
                return self.bad(key("face_velocity"), format!("unknown face {f:?}"));
            }
            if w.kind == WallKind::Solid {
                return self.bad(key("face_velocity"), "applies to container faces");
            }
            if w.open.contains(f) {
                return self.bad(key("face_velocity"), format!("face {f} is open"));
            }
            self.vector(&key(&format!("face_velocity.{f}")), v)?;
        }
        Ok(())
    }

    /// With containers in the scene, every fluid block must overlap the inside of one of them
    /// (open faces reaching to infinity): a block wholly outside every container would fall
    /// or drift away past it.
    fn fluid_in_containers(&self) -> Check {
        let s = self.scene;
        let inside: Vec<([f64; 3], [f64; 3])> = s
            .wall
            .iter()
            .filter(|w| w.kind == WallKind::Container)
            .map(|w| {
                let (mut lo, mut hi) = ([f64::NEG_INFINITY; 3], [f64::INFINITY; 3]);
                lo[..s.dim].copy_from_slice(&w.min[..s.dim]);
                hi[..s.dim].copy_from_slice(&w.max[..s.dim]);
                for f in &w.open {
                    if let Some((k, upper)) = crate::blocks::face_index(f) {
                        if upper {
                            hi[k] = f64::INFINITY;
                        } else {
                            lo[k] = f64::NEG_INFINITY;
                        }
                    }
                }
                (lo, hi)
            })
            .collect();
        for (i, b) in s.fluid.iter().enumerate() {
            let (blo, bhi) = block_bounds(b, s.dim);
            if let Some(j) = s.wall.iter().position(|w| {
                w.kind == WallKind::Solid
                    && (0..s.dim).all(|k| blo[k] >= w.min[k] && bhi[k] <= w.max[k])
            }) {
                return self.bad(
                    format!("fluid[{i}]"),
                    format!(
                        "lies wholly inside the solid wall[{j}]: its particles would all be \
                         carved away"
                    ),
                );
            }
        }
        if inside.is_empty() {
            return Ok(());
        }
        for (i, b) in s.fluid.iter().enumerate() {
            let (blo, bhi) = block_bounds(b, s.dim);
            let overlaps = inside
                .iter()
                .any(|(lo, hi)| (0..s.dim).all(|k| bhi[k] > lo[k] && blo[k] < hi[k]));
            if !overlaps {
                return self.bad(
                    format!("fluid[{i}]"),
                    format!(
                        "lies wholly outside every container [[wall]] (its extent {:?} to \
                         {:?}): it would never meet the walls",
                        &blo[..s.dim],
                        &bhi[..s.dim]
                    ),
                );
            }
        }
        Ok(())
    }

    fn domain(&self) -> Check {
        let s = self.scene;
        let Some(d) = &s.domain else { return Ok(()) };
        if d.periodic.is_empty() {
            return self.bad(
                "domain.periodic",
                "names no axis (a [domain] table declares periodic axes)",
            );
        }
        let mut axes = [false; 3];
        for a in &d.periodic {
            match axis_index(a) {
                Some(k) if k < s.dim => {
                    if axes[k] {
                        return self.bad("domain.periodic", format!("names {a:?} twice"));
                    }
                    axes[k] = true;
                }
                _ => return self.bad("domain.periodic", format!("unknown axis {a:?}")),
            }
        }
        let (Some(lo), Some(hi)) = (&d.min, &d.max) else {
            return self.bad("domain.min", "min and max of the periodic box are required");
        };
        self.vector("domain.min", lo)?;
        self.vector("domain.max", hi)?;
        for k in 0..s.dim {
            if !axes[k] {
                continue;
            }
            let period = hi[k] - lo[k];
            if !positive(period) {
                return self.bad("domain.max", "must exceed min along periodic axes");
            }
            self.on_lattice("domain.min", &[lo[k]])?;
            self.on_lattice("domain.max", &[hi[k]])?;
            if 2.0 * s.support() >= period {
                return self.bad(
                    "domain.max",
                    format!(
                        "the period {period} along {} must exceed twice the kernel support {}",
                        ["x", "y", "z"][k],
                        s.support()
                    ),
                );
            }
            for (i, b) in s.fluid.iter().enumerate() {
                let (blo, bhi) = block_bounds(b, s.dim);
                if blo[k] < lo[k] - 1e-9 * period || bhi[k] > hi[k] + 1e-9 * period {
                    return self.bad(
                        format!("fluid[{i}]"),
                        format!(
                            "spans {:.6} to {:.6} along the periodic axis {}, beyond the periodic \
                             box [{}, {}]: its particles outside the box would be dropped",
                            blo[k],
                            bhi[k],
                            ["x", "y", "z"][k],
                            lo[k],
                            hi[k]
                        ),
                    );
                }
            }
            for (i, w) in s.wall.iter().enumerate() {
                let closed = |upper: bool| {
                    let f = format!("{}{}", if upper { "+" } else { "-" }, ["x", "y", "z"][k]);
                    !w.open.contains(&f)
                };
                if w.kind == WallKind::Container && (closed(false) || closed(true)) {
                    return self.bad(
                        format!("wall[{i}].open"),
                        format!(
                            "a container's faces normal to the periodic axis {} must be open",
                            ["x", "y", "z"][k]
                        ),
                    );
                }
                if w.min[k] < lo[k] - 1e-12 || w.max[k] > hi[k] + 1e-12 {
                    return self.bad(
                        format!("wall[{i}].max"),
                        "must lie inside the periodic box along periodic axes",
                    );
                }
            }
        }
        Ok(())
    }

    fn output(&self) -> Check {
        let o = &self.scene.output;
        if o.sample_every == Some(0) {
            return self.bad("output.sample_every", "must be at least 1");
        }
        if o.frame_every == Some(0) {
            return self.bad("output.frame_every", "must be at least 1");
        }
        if o.snapshots.iter().any(|t| !(t.is_finite() && *t >= 0.0)) {
            return self.bad("output.snapshots", "must be non-negative times");
        }
        Ok(())
    }

    fn limits(&self) -> Check {
        let l = &self.scene.limits;
        if l.max_particles == Some(0) {
            return self.bad("limits.max_particles", "must be at least 1");
        }
        if l.max_steps == Some(0) {
            return self.bad("limits.max_steps", "must be at least 1");
        }
        if l.max_memory_gb.is_some_and(|m| !positive(m)) {
            return self.bad("limits.max_memory_gb", "must be positive");
        }
        if l.max_displacement.is_some_and(|m| !positive(m)) {
            return self.bad(
                "limits.max_displacement",
                "must be positive (in smoothing lengths)",
            );
        }
        if l.max_speed_ratio.is_some_and(|m| !positive(m)) {
            return self.bad(
                "limits.max_speed_ratio",
                "must be positive (a multiple of the flow's velocity scale)",
            );
        }
        Ok(())
    }

    fn checks(&self) -> Check {
        for (i, c) in self.scene.check.iter().enumerate() {
            if c.quantity.trim().is_empty() {
                return self.bad(format!("check[{i}].quantity"), "must name a result");
            }
            if c.min.is_none() && c.max.is_none() {
                return self.bad(format!("check[{i}]"), "needs min or max");
            }
            if c.min.iter().chain(&c.max).any(|v| !v.is_finite()) {
                return self.bad(format!("check[{i}]"), "bounds must be finite");
            }
            if let (Some(a), Some(b)) = (c.min, c.max)
                && a > b
            {
                return self.bad(format!("check[{i}]"), "min exceeds max");
            }
            if c.known_failure
                .as_ref()
                .is_some_and(|w| w.trim().is_empty())
            {
                return self.bad(format!("check[{i}].known_failure"), "must say why");
            }
            if let Some(k) = c.schemes.iter().find(|k| !self.scene.schemes.contains(k)) {
                return self.bad(
                    format!("check[{i}].schemes"),
                    format!("{} is not among the scene's schemes", k.name()),
                );
            }
        }
        Ok(())
    }

    fn quick(&self) -> Check {
        if let Some(q) = &self.scene.quick {
            if q.dx.is_some_and(|v| !positive(v)) {
                return self.bad("quick.dx", "must be a positive number");
            }
            if q.dt.is_some_and(|v| !positive(v)) {
                return self.bad("quick.dt", "must be a positive number");
            }
            if q.t_end.is_some_and(|v| !positive(v)) {
                return self.bad("quick.t_end", "must be a positive number");
            }
            if q.check_ghia.is_some() && self.scene.cavity.is_none() {
                return self.bad("quick.check_ghia", "applies to lid_driven_cavity scenes");
            }
        }
        Ok(())
    }

    /// What the scene would allocate and run, against its limits (before allocating).
    fn budget(&self) -> Check {
        let s = self.scene;
        let e = s.estimate();
        let l = &s.limits;
        if s.steps().0 == 0 {
            return self.bad(
                "dt",
                format!(
                    "= {} is longer than t_end = {}: the run would take no full step",
                    s.dt, s.t_end
                ),
            );
        }
        // A spacing so small that the counts overflow (or the estimate's arithmetic gives NaN)
        // is over every limit: the comparisons below would let NaN through.
        if ![e.fluid, e.walls, e.probes, e.bytes, e.steps]
            .iter()
            .all(|v| v.is_finite())
        {
            return self.bad(
                "dx",
                format!(
                    "= {:e} (with dt = {:e}) is too small to count the particles or steps it \
                     would create (limits: {} particles, {} steps)",
                    s.dx,
                    s.dt,
                    l.particles(),
                    l.steps()
                ),
            );
        }
        if e.fluid < MIN_FLUID_ESTIMATE {
            return self.bad(
                "dx",
                format!(
                    "= {} resolves the fluid with about {:.0} particles; a run needs at least {}",
                    s.dx, e.fluid, MIN_FLUID_ESTIMATE
                ),
            );
        }
        if e.steps > l.steps() as f64 {
            return self.bad(
                "t_end",
                format!(
                    "needs {:.3e} steps of dt = {:e}{} (limit {}; raise [limits] max_steps)",
                    e.steps,
                    s.step_bound().0,
                    match s.step_bound().1 {
                        Some(b) if b != DtBound::Scene => format!(
                            ", the automatic step's {}",
                            b.name().trim_start_matches("the ")
                        ),
                        _ => String::new(),
                    },
                    l.steps()
                ),
            );
        }
        if e.particles() + e.probes > l.particles() as f64 {
            return self.bad(
                "dx",
                format!(
                    "= {} would create about {:.3e} particles{} (limit {}; raise [limits] \
                     max_particles)",
                    s.dx,
                    e.particles(),
                    if e.probes > 0.0 {
                        format!(" and {:.3e} probes", e.probes)
                    } else {
                        String::new()
                    },
                    l.particles()
                ),
            );
        }
        if e.bytes > l.memory_bytes() {
            return self.bad(
                "dx",
                format!(
                    "= {} would need about {:.2} GiB ({:.3e} particles × {:.0} neighbours; limit \
                     {:.2} GiB; raise [limits] max_memory_gb)",
                    s.dx,
                    e.bytes / (1u64 << 30) as f64,
                    e.particles(),
                    e.neighbors,
                    l.memory_bytes() / (1u64 << 30) as f64
                ),
            );
        }
        Ok(())
    }
}

/// `message` with every line cut to `width` characters (a parser echoes the offending line,
/// which in a damaged file can be megabytes long).
fn clip_lines(message: &str, width: usize) -> String {
    message
        .lines()
        .map(|l| match l.char_indices().nth(width) {
            Some((cut, _)) => format!("{} …", &l[..cut]),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests;
