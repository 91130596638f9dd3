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
    /// `∫ r² W(r) dV` over the support: `M₂ h²` with the shape's dimensionless
    /// [`second_moment`](crate::Shape::second_moment).
    fn second_moment(&self) -> f64;
    /// `W(r)`.
    fn w(&self, r: f64) -> f64;
    /// `dW/dr (r)`; zero at `r = 0` and beyond the support.
    fn dw_dr(&self, r: f64) -> f64;
    /// The scalar `s_ij = (dW/dr)(r) / r` of `∇_i W(x_ij) = s_ij x_ij`, for `r = |x_ij|`; zero
    /// for `r = 0`. [`grad_w`](Kernel::grad_w) is `x_ij · grad_factor(x_ij)`, so a factor
    /// computed once per pair and reused gives the same bits as a fresh `grad_w`.
    #[inline(always)]
    fn grad_factor(&self, x_ij: D::Vector) -> f64 {
        self.grad_factor_at(x_ij.length())
    }
    /// [`grad_factor`](Kernel::grad_factor) at the distance `r = |x_ij|`, for a caller that
    /// also needs `W(r)` from the same square root.
    #[inline(always)]
    fn grad_factor_at(&self, r: f64) -> f64 {
        if r > 0.0 { self.dw_dr(r) / r } else { 0.0 }
    }
    /// `∇_i W(x_ij) = dW/dr · x_ij / r` with `x_ij = x_i − x_j`; zero for `r = 0`.
    #[inline(always)]
    fn grad_w(&self, x_ij: D::Vector) -> D::Vector {
        x_ij * self.grad_factor(x_ij)
    }
}
