use sph_core::{Dim, VectorOps};
use std::fmt;

/// A radially symmetric SPH smoothing kernel in dimension `D`.
///
/// `W(r) = σ_D / h^D · f(r/h)` with compact support `[0, support_radius]`.
pub trait Kernel<D: Dim>: Send + Sync + fmt::Debug + Clone {
    /// Smoothing length `h`.
    fn h(&self) -> f64;
    /// Radius beyond which `W` and `∇W` vanish (`κ h`).
    fn support_radius(&self) -> f64;
    /// `W(r)`.
    fn w(&self, r: f64) -> f64;
    /// `dW/dr (r)`; zero at `r = 0` and beyond the support.
    fn dw_dr(&self, r: f64) -> f64;
    /// `∇_i W(x_ij) = dW/dr · x_ij / r` with `x_ij = x_i − x_j`; zero for `r = 0`.
    #[inline(always)]
    fn grad_w(&self, x_ij: D::Vector) -> D::Vector {
        let r = x_ij.length();
        if r > 0.0 {
            x_ij * (self.dw_dr(r) / r)
        } else {
            D::Vector::ZERO
        }
    }
}
