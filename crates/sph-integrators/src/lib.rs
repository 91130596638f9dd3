//! # sph-integrators
//!
//! Time-update schemes of incompressible SPH behind one `Integrator` interface: first-order
//! Euler ISPH, Cummins–Rudman predictor–corrector ISPH (paper Algorithm 2) and the
//! deformation-gradient DG-ISPH (paper Algorithm 1).
//!
//! Status: the schemes land with the ISPH-schemes issue.
