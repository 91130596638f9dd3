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
    /// Defaults: 1.5 in 2D (Lee et al. 2008; the paper's Ref. [17]) and 2.25 = 0.75 d in 3D,
    /// the same fraction of the bulk value. Lower thresholds flag fewer particles (p = 0 sits
    /// closer to the true surface) but may miss surface particles at convex tips.
    pub div_r_threshold: f64,
}

impl FreeSurface {
    /// The documented default threshold for dimension `dim`.
    pub fn default_for(dim: usize) -> Self {
        Self {
            div_r_threshold: 0.75 * dim as f64,
        }
    }
}

/// Laminar viscosity (Morris et al. 1997): `u* += Δt ν ∇²uⁿ`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Viscosity {
    /// Kinematic viscosity `ν`.
    pub nu: f64,
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
    /// Linear solver. Default BiCGSTAB + Jacobi.
    pub solver: SolverKind,
    /// Solver tolerances.
    pub solve: SolveParams,
    /// Neighbour search backend. Default cell grid.
    pub search: SearchKind,
    /// Compute the det F diagnostics of every step (one extra operator pass; for the
    /// predictor–corrector also one extra neighbour search). Default `true`.
    pub diagnostics: bool,
    /// Explicit forces and shifting. Default: none.
    pub effects: Effects,
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
            solver: SolverKind::BicgstabJacobi,
            solve: SolveParams::default(),
            search: SearchKind::CellGrid,
            diagnostics: true,
            effects: Effects::default(),
        }
    }
}
