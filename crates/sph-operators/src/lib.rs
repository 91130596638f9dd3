//! # sph-operators
//!
//! The discrete SPH operators of dgsph, generic over dimension, on plain particle arrays.
//!
//! Every operator reads a [`SphContext`] — positions, particle volumes `V_j = m_j/ρ_j`, the
//! step's [`NeighborList`](neighbors::NeighborList) and a [`Kernel`](kernels::Kernel) — and writes
//! one value per particle into a caller-owned slice (no allocation, one rayon task per chunk of
//! particles, each particle writing only its own slot, so results do not depend on the thread
//! count). The per-particle operators below (the gradients, divergence, viscous term and
//! shifting gradients) also take a shorter output slice and then compute only the first
//! `out.len()` particles, bitwise as the full pass would: a caller whose trailing particles
//! need no value (walls numbered after the fluid) skips them.
//! Pair loops go through [`SphContext::for_each_pair`]; a step that runs several
//! operators on one neighbour list computes the kernel-gradient factors once
//! ([`grad_factors`]) and attaches them ([`SphContext::with_grad_factors`]) — same bits, less
//! arithmetic.
//!
//! | operator | discrete form | paper |
//! |---|---|---|
//! | [`density_summation`], [`density_at_points`] | ρ_a = Σ_b m_b W_ab | Eq. 31 |
//! | [`kernel_sum_excess`], [`lattice_kernel_sum`] | Σ_j V_j W_ij / S_lattice − 1 | Eq. 31 over a perfect lattice's |
//! | [`kernel_sum_excess_near_surface`], [`CutLattice`] | Σ_j V_j W_ij / S(R_i) − 1, S(R) a lattice cut by a flat face at the depth the truncation ratio R_i says | Eq. 31 in a free surface's band |
//! | [`surface_depths`] | δ_i = Δx depth(R_i): a surface particle's distance to the surface from its truncation ratio | where a Robin row puts p = 0 (not in the paper) |
//! | [`gradient`] | Σ V_j (f_j − f_i) ∇W_ij, or the symmetric Σ V_j (f_i + f_j) ∇W_ij | — |
//! | [`lattice_gradient_factor`] | β = −(1/D) Σ_k V x_k·∇W(x_k) over a perfect lattice | its lattice error |
//! | [`divergence`] | Σ V_j (u_j − u_i)·∇W_ij | Eq. 3 source |
//! | [`velocity_gradient`], [`deformation_gradient`] | F = I + Σ V_j (Δx_j − Δx_i) ⊗ ∇W_ij | Eq. 26 |
//! | [`laplacian`] | 2 Σ V_j (f_i − f_j) F_ij (Morris 1997) | Eq. 3 LHS |
//! | [`hessian`] | Σ V_j ((d+2) x̂⊗x̂ − I)(f_i − f_j) F_ij | Eq. 25 (corrected) |
//! | [`hessian_quadratic_fit`] | weighted least-squares gradient + Hessian, exact for quadratics | — |
//! | [`free_surface_indicator`] | ∇·r = Σ V_j (x_j − x_i)·∇W_ij | Nair & Tomar 2014 |
//! | [`free_surface_scan`] | no neighbour in the umbrella region outside `x_i` | Marrone et al. 2010 |
//! | [`viscous_acceleration`] | Σ m_j (μ_i+μ_j)/(ρ_iρ_j) F_ij (u_i − u_j) (Morris 1997) | Eq. 1 viscous term |
//! | [`hyperviscous_acceleration`], [`lattice_laplacian_bound`] | −ν₄ L(l), l_i = Σ_j w_ij (u_i − u_j − ½(G_i + G_j) x_ij), w_ij = 2 V_j F_ij: zero for linear fields, ∝ k⁶ on smooth modes | — (particle-scale dissipation) |
//! | [`viscous_correction`] | a_i − c (L a)_i, c = M₂/(4D) ([`morris_error_coefficient`]): ν∇²u to O(h⁴) | Eq. 1 viscous term, fourth order |
//!
//! with `F_ij = x_ij·∇W_ij / (r_ij² + (0.01h)²)` and `x_ij = x_i − x_j`. Optional kernel-gradient
//! renormalisation ([`correction_matrices`], `∇̃W_ij = L_i ∇W_ij`) makes the gradient, divergence
//! and deformation gradient exact for linear fields on any non-degenerate particle cloud.
//!
//! **Paper errata pinned by tests.** Eq. 25 prints the coefficient 4 in `(4 x̂⊗x̂ − δ)`; that is
//! `d + 2` only in 2D. In 3D it must be 5: with 4 the trace of the Hessian is half the Laplacian
//! and the diagonal of a quadratic field with H = diag(2, 4, 6) comes out as `0.8 H − 1.2` =
//! (0.4, 2.0, 3.6) in the continuum limit (see `hessian::tests::papers_2d_coefficient_fails_in_3d`).
//!
//! This crate depends only on the kernel and neighbour crates, which it re-exports with
//! `sph-core` and `glam`, so a downstream crate can depend on `sph-operators` alone (the crate
//! `tests/downstream` of the workspace does exactly that):
//!
//! ```
//! use sph_operators::core::{D2, Dim, VectorOps, testing::lattice};
//! use sph_operators::kernels::{Kernel, QuinticSpline};
//! use sph_operators::neighbors::{CellGrid, NeighborList, NeighborSearch};
//! use sph_operators::glam::DVec2;
//! use sph_operators::{SphContext, divergence};
//!
//! // Your own particle arrays: a 21 × 21 lattice with spacing dx and the field u = (−x, y).
//! let dx = 0.05;
//! let positions: Vec<DVec2> = lattice::<D2>(21, dx);
//! let velocities: Vec<DVec2> = positions.iter().map(|x| DVec2::new(-x.x, x.y)).collect();
//! let volumes = vec![dx * dx; positions.len()];
//!
//! let kernel = QuinticSpline::<D2>::new(1.3 * dx);
//! let mut grid = CellGrid::<D2>::new();
//! grid.build(&positions, kernel.support_radius()).unwrap();
//! let mut neighbors = NeighborList::new();
//! grid.query(&positions, &mut neighbors);
//!
//! let ctx = SphContext::new(&positions, &volumes, &neighbors, &kernel);
//! let mut div = vec![0.0; positions.len()];
//! divergence(&ctx, &velocities, None, &mut div);
//! let centre = positions.len() / 2;
//! assert!(div[centre].abs() < 1e-10); // ∇·u = 0 exactly at an interior particle
//! ```
//!
//! The same code runs in 3D with `D3`, `DVec3` and `lattice::<D3>`.

mod context;
mod correction;
mod deformation;
mod density;
mod divergence;
mod free_surface;
mod gradient;
mod hessian;
mod hyperviscosity;
mod laplacian;
mod quadratic_fit;
mod shifting;
#[cfg(test)]
mod test_support;
mod viscosity;

pub use context::{
    PAIR_BLOCK, Pair, SphContext, grad_factors, grad_factors_and_values,
    grad_factors_from_squared_distances, laplacian_regulariser, pair_f, pair_f_of,
};
pub use correction::{CorrectionStats, correction_matrices};
pub use deformation::{Invariants, deformation_gradient, invariants, velocity_gradient};
pub use density::{
    CutLattice, MAX_SURFACE_DEPTH, MissingMoments, density_at_points, density_summation,
    kernel_sum_excess, kernel_sum_excess_near_surface, lattice_kernel_sum, surface_depths,
};
pub use divergence::divergence;
pub use free_surface::{free_surface_indicator, free_surface_scan};
pub use gradient::{GradientForm, gradient, lattice_gradient_factor};
pub use hessian::{HessianForm, hessian, hessian_stencil_eq25, hessian_stencil_eq25_contracted};
pub use hyperviscosity::{hyperviscous_acceleration, lattice_laplacian_bound};
pub use laplacian::laplacian;
pub use quadratic_fit::{QuadraticFitStats, hessian_quadratic_fit, hessian_stencil_fit};
pub use shifting::{concentration_gradient, shifting_gradients};
pub use viscosity::{morris_error_coefficient, viscous_acceleration, viscous_correction};

/// The dimension abstraction (re-export of `sph-core`).
pub use sph_core as core;
/// The vector and matrix types `D2`/`D3` map to (re-export of `glam`).
pub use sph_core::glam;
/// Smoothing kernels (re-export of `sph-kernels`).
pub use sph_kernels as kernels;
/// Neighbour search (re-export of `sph-neighbors`).
pub use sph_neighbors as neighbors;
#[cfg(test)]
mod tests;
