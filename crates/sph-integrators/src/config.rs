use serde::{Deserialize, Serialize};
use sph_kernels::KernelKind;
use sph_neighbors::SearchKind;
use sph_operators::{GradientForm, HessianForm};
use sph_pressure::{SolveParams, SolverKind};

/// Free-surface treatment: particles whose position divergence `∇·r` is below the threshold get
/// Dirichlet rows `p = 0`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreeSurface {
    /// `∇·r` threshold. Bulk values are `d` (2 or 3); a flat face gives ≈ 0.6 d–0.68 d.
    /// Defaults: 1.5 in 2D (Lee et al. 2008; the paper's Ref. \[17\]) and 2.25 = 0.75 d in 3D,
    /// the same fraction of the bulk value. Lower thresholds flag fewer particles (p = 0 sits
    /// closer to the true surface) but may miss surface particles at convex tips.
    pub div_r_threshold: f64,
    /// Also flag a particle whose umbrella region outside it is empty (the scan of Marrone et
    /// al. 2010, `sph_operators::free_surface_scan`): catches surface particles that a crowded
    /// neighbourhood lifts above the `∇·r` threshold. Default `false` (the paper's `∇·r` alone).
    #[serde(default)]
    pub scan: bool,
    /// Where `p = 0` is imposed: at the free-surface particles (`0`, the paper's Dirichlet
    /// rows) or this distance outside them along the surface normal (a Robin row
    /// `p_i + δ n_i·∇p_i = 0`, see `sph_pressure::assemble_surface_rows`; `Δx/2` puts it where
    /// a lattice's fluid ends). Default 0.
    #[serde(default)]
    pub zero_pressure_depth: f64,
    /// Complete the pressure rows of the unflagged particles in the surface's band (a
    /// free-surface particle in their support) with the neighbours a lattice would have beyond
    /// a flat surface at their depth, read as `p = 0` (`sph_pressure::complete_cut_rows`),
    /// instead of as a zero flux into the air. Default `false`.
    #[serde(default)]
    pub complete_band: bool,
    /// With Robin rows (`zero_pressure_depth` > 0): put the `p = 0` of each surface particle
    /// whose last pressure is positive at the distance its truncation says it stands below a
    /// flat surface (`sph_operators::surface_depths`: `Δx/2` on a lattice's top row, more for a
    /// particle sunk into the row below, at most one spacing) instead of at
    /// `zero_pressure_depth`, which the others keep (where the surface is in tension it breaks
    /// the Taylor sign condition, and a depth read from its disorder feeds that). Default `false`.
    #[serde(default)]
    pub measured_depth: bool,
}

impl FreeSurface {
    /// The documented default threshold for dimension `dim`.
    pub fn default_for(dim: usize) -> Self {
        Self {
            div_r_threshold: 0.75 * dim as f64,
            scan: false,
            zero_pressure_depth: 0.0,
            complete_band: false,
            measured_depth: false,
        }
    }
}

/// Particle-scale dissipation: `u* += Δt a`, `a` the hyperviscous acceleration of
/// [`hyperviscous_acceleration`](sph_operators::hyperviscous_acceleration) at `xⁿ` with
/// `ν₄ = speed · h³` (zero for every linear field, a damping rate `∝ ν₄ k⁶ h²` on a smooth mode
/// of wavenumber `k`, `∝ speed/h` on the particle scale). Not in the paper.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hyperviscosity {
    /// The speed `C` in `ν₄ = C h³` (m/s).
    pub speed: f64,
    /// Where the term acts.
    #[serde(default)]
    pub region: HyperviscousRegion,
}

/// The fluid particles on which [`Hyperviscosity`] acts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HyperviscousRegion {
    /// Every fluid particle.
    #[default]
    Everywhere,
    /// Only where the particle's pressure from the previous step is positive, `pⁿ_i > 0`: not at
    /// the free surface (`p = 0`) nor where the fluid is in tension, where the particle-scale
    /// motion is the tensile instability's and damping it takes the flow's energy (the rotating
    /// square; docs/hard-cases.md). Meaningful only where the pressure's level is fixed, by a
    /// free surface.
    PositivePressure,
}

/// The explicit hyperviscous step's limit `Δt ≤ K/(ν₄ λ_G²)`, this `K`. Forward Euler on a
/// damping rate `|λ|` is stable for `Δt |λ| ≤ 2`; the operator's spectral radius on blocks with
/// free edges is 0.47 / 0.65 / 0.85 `ν₄ λ_G²` in 2D (perfect, 20 %, 30 % jitter) and 0.35 /
/// 0.43 / 0.50 in 3D (`sph_operators`' test `the_lattice_bound_bounds_the_spectrum_on_disordered_blocks`),
/// so at this limit `Δt |λ|` is at most 0.95 / 1.3 / 1.7 in 2D and 0.70 / 0.86 / 1.0 in 3D.
pub const HYPERVISCOUS_STEP: f64 = 2.0;

impl Hyperviscosity {
    /// `ν₄ λ_G²` (1/s), `λ_G` Morris' Laplacian's eigenvalue bound on a perfect lattice of
    /// particle volume `volume` ([`lattice_laplacian_bound`](sph_operators::lattice_laplacian_bound)):
    /// the explicit hyperviscous step is kept stable by `Δt ≤` [`HYPERVISCOUS_STEP`]`/(ν₄ λ_G²)`.
    /// The automatic time step counts it in its viscous limit as the viscosity
    /// `C_ν h² ν₄ λ_G² / K` (whose limit is that one).
    pub fn rate<D: sph_core::Dim, K: sph_kernels::Kernel<D>>(
        &self,
        kernel: &K,
        volume: f64,
    ) -> f64 {
        let h = kernel.h();
        let bound = sph_operators::lattice_laplacian_bound::<D, K>(kernel, volume);
        self.speed * h.powi(3) * bound * bound
    }
}

/// Laminar viscosity (Morris et al. 1997): `u* += Δt ν ∇²uⁿ`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Viscosity {
    /// Kinematic viscosity `ν`.
    pub nu: f64,
    /// The discrete `∇²u`.
    #[serde(default)]
    pub operator: ViscousOperator,
}

impl Viscosity {
    /// Viscosity `ν` with Morris' operator (the paper's).
    pub fn morris(nu: f64) -> Self {
        Self {
            nu,
            operator: ViscousOperator::Morris,
        }
    }
}

/// The discrete Laplacian of the viscous term.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ViscousOperator {
    /// Morris et al. (1997), Eq. (8): second order, `L = ∇² + c∇⁴ + O(h⁴)`
    /// (`sph_operators::morris_error_coefficient`).
    #[default]
    Morris,
    /// Morris' operator with its leading error removed, `L − c L²`
    /// (`sph_operators::viscous_correction`), at fluid particles whose neighbourhood holds
    /// neither a wall nor a free-surface particle (Morris' elsewhere).
    Corrected,
}

/// Fickian particle shifting after Lind et al. (2012), J. Comput. Phys. 231, 1499, Eqs. (7)–(9):
///
/// ```text
/// δr_i = −D ∇C_i,   D = A h |u_i| Δt,
/// ∇C_i = Σ_j V_j (1 + R (W_ij / W(Δp))⁴) ∇W_ij,   R = 0.2,  Δp = h / h_over_dx
/// ```
///
/// followed by the Taylor correction `u_i += (δr_i·∇) u_i`. Off unless a scene declares it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shifting {
    /// `A` (Lind et al. use 2; larger shifts more).
    pub coefficient: f64,
    /// Initial particle spacing `Δp` used in the anti-clumping term.
    pub spacing: f64,
    /// Which speed scales the diffusion coefficient `D = A h U Δt`.
    pub scale: ShiftScale,
    /// How the velocity follows the shift.
    pub velocity_correction: ShiftVelocity,
}

/// How density relaxation ([`SimConfig::density_relaxation`]) moves particles back towards the
/// lattice's packing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DensityRelaxationForm {
    /// Through the projection's target divergence (`∇·u_i = α e_i/Δt`; DG: `det A_i − 1 = α
    /// e_i`): the velocities carry the correction (Asai et al. 2012).
    #[default]
    Velocity,
    /// Through a second Poisson solve whose potential displaces the particles
    /// (`δr_i = −Δt² ∇q_i/ρ_i`, `∇·((1/ρ)∇q)_i = −α e_i/Δt²`): the velocities are untouched.
    Position,
}

/// How a shifted particle's velocity is carried to its new position.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShiftVelocity {
    /// The Taylor correction `u_i += (∇u)_i δr_i` (Xu et al. 2009).
    #[default]
    Taylor,
    /// The Taylor correction, each component limited to the range of the particle's and its
    /// neighbours' velocities, so the interpolation creates no new extremum.
    Limited,
    /// None: the particle keeps its velocity.
    None,
}

/// The speed `U` in the shifting coefficient `D = A h U Δt`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShiftScale {
    /// The particle's own speed `|u_i|` (Skillen et al. 2013; Lind et al. 2012): no shifting
    /// where the fluid is at rest.
    #[default]
    Local,
    /// The largest fluid speed of the step, `max_j |u_j|`, for every particle (Sun et al. 2017,
    /// δ⁺-SPH: `CFL · Ma = U_max Δt / h`): stagnation points and slow cores are regularised
    /// as strongly as the fast parts of the flow.
    Max,
    /// The particle's own speed where its new pressure is not negative, the largest fluid speed
    /// where it is (`p_i < 0`): the anti-clumping shift acts at full strength where the tensile
    /// instability can pair particles, even where the fluid is slow, and stays the local one
    /// everywhere else. Meaningful only where the pressure's level is fixed (a free surface
    /// with `p = 0`).
    Tension,
}

/// Explicit terms of the momentum equation and particle regularisation. Each is computed only
/// when present: a flow that declares none runs no loop for them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Effects {
    /// Laminar viscosity.
    pub viscosity: Option<Viscosity>,
    /// Body-force acceleration (`x, y, z`; the `z` entry is ignored in 2D).
    pub gravity: Option<[f64; 3]>,
    /// Particle shifting.
    pub shifting: Option<Shifting>,
    /// Particle-scale dissipation.
    pub hyperviscosity: Option<Hyperviscosity>,
}

/// Per-step diagnostics: measurements of a step that the step itself does not need. Each one
/// costs a pass over the particles and runs only when asked for (a scene's `[output]`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Diagnostics {
    /// `det F` of the step's displacement (paper Eq. 26): one deformation-gradient pass, and for
    /// the viscous predictor–corrector the neighbour lists at `xⁿ` kept aside.
    pub det_f: bool,
    /// `max |∇·uⁿ⁺¹|` after the projection: the walls' boundary data of `uⁿ⁺¹` and one
    /// divergence pass.
    pub div_u: bool,
}

impl Diagnostics {
    /// Every diagnostic on.
    pub const ALL: Diagnostics = Diagnostics {
        det_f: true,
        div_u: true,
    };
}

/// Periodic axes of the domain: the box `[lo, hi)`, periodic along the axes with `axes[k]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeriodicAxes {
    /// Lower corner (`z` ignored in 2D).
    pub lo: [f64; 3],
    /// Upper corner.
    pub hi: [f64; 3],
    /// Which axes are periodic.
    pub axes: [bool; 3],
}

/// What ends a step as a blow-up ([`StepError::BlowUp`](crate::StepError::BlowUp)) instead of
/// letting it pass silently.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest displacement of a particle in one step, in smoothing lengths. A particle moving
    /// further than `h` in a step leaves the neighbourhood the step was computed on. Default 1.
    /// (The paper's drop moves its tip 0.62 h per step.)
    pub max_displacement: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_displacement: 1.0,
        }
    }
}

/// Numerical configuration of a simulation, shared by all schemes.
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// Smoothing kernel.
    pub kernel: KernelKind,
    /// Smoothing length `h`.
    pub h: f64,
    /// Reference density `ρ₀` (particle densities stay at their initial values in ISPH).
    pub rho0: f64,
    /// Free surface, if the flow has one. `None`: no Dirichlet rows (walls come later).
    pub free_surface: Option<FreeSurface>,
    /// Gradient used for the velocity correction. Default: `Difference` (with renormalisation
    /// ≈ 40× smaller volume errors than the symmetric form in the drops).
    pub gradient: GradientForm,
    /// Apply kernel-gradient renormalisation to ∇·u*, ∇u* and ∇p. Default `true`.
    pub renormalise: bool,
    /// Hessian in the DG equation. Default `Eq25` (the paper's, coefficient corrected).
    pub dg_hessian: HessianForm,
    /// Make the pressure equation's Laplacian (or DG Hessian) exact for linear fields on any
    /// particle arrangement, with the renormalised gradient (Fatehi & Manzari 2011; see
    /// `sph_pressure::assemble_ppe`). A hydrostatic pressure is then an exact discrete solution
    /// of a disordered particle set; needs `renormalise`. Default `false` (the paper's operators).
    pub consistent_laplacian: bool,
    /// Complete the pressure equation with the divergence of the symmetric gradient's
    /// constant-pressure part (`sph_pressure::add_level_term`), so the projection is the one the
    /// velocity correction applies at any pressure level. Only with
    /// [`GradientForm::Symmetric`] without renormalisation. Default `false`; flow scenes turn it
    /// on (docs/physics.md, "The symmetric gradient at a pressure level").
    pub level_consistent: bool,
    /// Divide each fluid particle's pressure gradient by `∇·r_i / D` (its free-surface
    /// indicator over the dimension: the trace of `−Σ_j V_j x_ij ⊗ ∇W_ij`, which is `β I` on a
    /// perfect lattice, see [`lattice_gradient_factor`](sph_operators::lattice_gradient_factor)),
    /// so the velocity correction applies the gradient the Laplacian stands for: on a lattice the
    /// divergence and Morris' Laplacian carry `β`, the gradient too, and without this the
    /// projection removes only the fraction `β` of the divergence per step and the pressure
    /// settles `1/β` high (2.7 % for Wendland C2 at `h = 1.3 Δx`). Particles in the free
    /// surface's band keep the plain gradient (there `∇·r` measures the support the surface cuts).
    /// Not with renormalisation (its gradient is exact for linear fields already). Default
    /// `false`; flow scenes turn it on (docs/physics.md, "The gradient's lattice factor").
    pub normalised_gradient: bool,
    /// Density relaxation `α` (Asai et al. 2012, J. Appl. Math. 2012, 139583): each step moves
    /// every fluid particle's summation density back towards a perfect lattice's by the fraction
    /// `α` of its excess `e_i`
    /// ([`kernel_sum_excess_near_surface`](sph_operators::kernel_sum_excess_near_surface)), so
    /// particles packed closer than their volumes stand for are moved apart (and spread ones
    /// drawn together) and the volume the velocity divergence alone lets drift is restored; how,
    /// [`density_relaxation_form`](Self::density_relaxation_form) says. In a free surface's band
    /// the sum is measured against a lattice cut at the particle's depth; the surface particles
    /// are left alone. `0` (the default): off (scenes of general flows turn it on;
    /// docs/physics.md).
    pub density_relaxation: f64,
    /// How density relaxation acts: through the velocities (default) or the positions.
    pub density_relaxation_form: DensityRelaxationForm,
    /// Linear solver. Default BiCGSTAB + AMG.
    pub solver: SolverKind,
    /// Solver tolerances.
    pub solve: SolveParams,
    /// Start each pressure solve from the last step's pressure (default) or from zero.
    pub warm_start: bool,
    /// Neighbour search backend. Default cell grid.
    pub search: SearchKind,
    /// Per-step diagnostics. Default: none.
    pub diagnostics: Diagnostics,
    /// Periodic axes. Default: none.
    pub periodic: Option<PeriodicAxes>,
    /// Blow-up limits.
    pub limits: Limits,
    /// Explicit forces and shifting. Default: none.
    pub effects: Effects,
    /// Renumber the fluid particles in cell order (the neighbour grid's cells of edge the kernel
    /// support, x fastest) at the start of every step whose number is a positive multiple of
    /// this, so that neighbours sit close in memory and the pair loops, the matrix products
    /// and the search stream through it. `0`: never (the default here; scenes default to 20).
    /// Only the order of floating-point sums changes; [`Simulation::ids`](crate::Simulation::ids)
    /// maps slots back to the initial numbering, which frames and error messages use.
    pub reorder_every: usize,
}

impl SimConfig {
    /// Defaults for a kernel and smoothing length.
    pub fn new(kernel: KernelKind, h: f64) -> Self {
        Self {
            kernel,
            h,
            rho0: 1.0,
            free_surface: None,
            gradient: GradientForm::Difference,
            renormalise: true,
            dg_hessian: HessianForm::Eq25,
            consistent_laplacian: false,
            level_consistent: false,
            normalised_gradient: false,
            density_relaxation: 0.0,
            density_relaxation_form: DensityRelaxationForm::Velocity,
            solver: SolverKind::BicgstabAmg,
            solve: SolveParams::default(),
            warm_start: true,
            search: SearchKind::CellGrid,
            diagnostics: Diagnostics::default(),
            periodic: None,
            limits: Limits::default(),
            effects: Effects::default(),
            reorder_every: 0,
        }
    }
}
