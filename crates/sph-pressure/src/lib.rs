//! # sph-pressure
//!
//! Pressure equations of incompressible SPH, assembled on the step's neighbour lists, and the
//! linear solvers behind them.
//!
//! * [`assemble_ppe`] — the pressure Poisson equation `∇·(∇p/ρ) = ∇·u*/Δt` (paper Eq. 3) with
//!   the Cummins & Rudman (1999) form of the Morris Laplacian.
//! * [`assemble_dg`] — the deformation-gradient equation of DG-ISPH (paper Eqs. 20–24,
//!   Algorithm 1) written for any dimension as `(Δt²/ρ) cof(A) : ∇∇p = det A − 1`.
//! * [`add_level_term`] — completes either with the divergence of the symmetric pressure
//!   gradient's constant-pressure part, so a projection with that gradient is consistent at any
//!   pressure level (the flow scenes' default).
//!
//! **Sign of the DG equation.** With the velocity correction of Algorithm 1,
//! `u = u* − Δt ∇p/ρ`, the step's deformation gradient is `F = A − (Δt²/ρ) ∇∇p` with
//! `A = I + ∇(Δt u*)`, and `det(A − E) = det A − cof(A):E + O(E²)`. Setting `det F = 1` gives
//! `(Δt²/ρ) cof(A):∇∇p = det A − 1`. The paper's Eqs. 20–23 use `ũ = +Δt∇p/ρ` and so print
//! `1 − det A` on the left; combined with Algorithm 1's minus sign that doubles the volume error
//! instead of removing it. The integrator tests check that a DG step gives `det F − 1 = O(Δt³)`.
//!
//! The matrix ([`CsrMatrix`]) shares its sparsity pattern with the neighbour list: row `i`'s
//! columns are particle `i`'s neighbours (self included), so assembly only fills values, in
//! parallel, one row per particle, no locks. Rows are scaled so that the diagonal is positive
//! (the PPE matrix is then a symmetric M-matrix away from Dirichlet rows).
//!
//! Free-surface particles get Dirichlet rows `p_i = 0`; their columns are eliminated from the
//! other rows (their known value is 0), which keeps the PPE matrix symmetric.
//!
//! Wall (dummy) particles get the pressure-extrapolation rows of [`assemble_wall_rows`]; a
//! closed domain (no Dirichlet row) fixes the free constant with [`MeanZeroGauge`].
//!
//! Solvers implement [`LinearSolver`]: [`BiCgStab`] with [`Preconditioner::Jacobi`],
//! [`Preconditioner::Ilu0`] or [`Preconditioner::Amg`] (smoothed-aggregation multigrid, the default of the
//! scenes: iterations nearly flat in the resolution), warm-started from the previous pressure, and
//! [`SparseLu`] (faer's
//! sparse LU, for small systems and as a test oracle). A solve is accepted when its true relative
//! residual meets the tolerance or, where round-off makes that unattainable, its backward error
//! does ([`CsrSystem::backward_error`], independent of the number of unknowns); anything else is
//! an error carrying the iteration count and the true residual.

mod assembly;
mod csr;
mod error;
pub mod solver;
mod walls;

pub use assembly::{
    DgHessian, PressureRhs, add_level_term, assemble_dg, assemble_ppe, complete_cut_rows,
};
pub use csr::CsrMatrix;
pub use error::{PressureError, SolveError};
pub use solver::{
    AnySolver, BiCgStab, Border, CsrSystem, GMRES_RESTART, Gmres, LinearSolver, Preconditioner,
    SolveInfo, SolveParams, SolverKind, SparseLu,
};
pub use walls::{MeanZeroGauge, assemble_surface_rows, assemble_wall_rows, fold_ghost_columns};
