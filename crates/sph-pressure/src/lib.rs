//! # sph-pressure
//!
//! Pressure equations of incompressible SPH and the linear solvers behind them:
//! the pressure Poisson equation `∇·(∇p/ρ) = ∇·u*/Δt` (paper Eq. 3) and the deformation-gradient
//! equation `(Δt²/ρ) cof(A):∇∇p = det A − 1` (paper Eqs. 23–24, with the sign derived in the
//! crate docs of `PressureScheme`), assembled row by row on the step's neighbour lists.
//!
//! Status: the assembly and solvers land with the ISPH-schemes issue; this crate is the place
//! for them in the layering `sph-operators ← sph-pressure ← sph-integrators`.
