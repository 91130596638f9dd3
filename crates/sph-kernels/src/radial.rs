use crate::kernel::Kernel;
use sph_core::Dim;
use std::fmt;
use std::marker::PhantomData;

/// The dimensionless shape of a radial kernel: `W(r) = σ_D / h^D · f(r/h)` on `[0, SUPPORT·h)`.
pub trait Shape: Copy + Send + Sync + fmt::Debug + 'static {
    /// Support radius in units of `h`.
    const SUPPORT: f64;
    /// Normalisation `σ_D` for dimension `dim` (2 or 3), such that `∫ W dV = 1`.
    fn sigma(dim: usize) -> f64;
    /// The second moment `M₂ = ∫ q² σ_D f(q) d^D q` for dimension `dim` (2 or 3), in units of
    /// `h²`: the width of the kernel that sets the leading error of its Laplacian (see
    /// `sph_operators::morris_error_coefficient`).
    fn second_moment(dim: usize) -> f64;
    /// `f(q)` for `0 ≤ q < SUPPORT`.
    fn f(q: f64) -> f64;
    /// `df/dq` for `0 ≤ q < SUPPORT`.
    fn df(q: f64) -> f64;
    /// The kernel-gradient factor `s = (dW/dr)/r` at `r = q h`, `0 < q < SUPPORT`, given
    /// `norm = σ_D/h^D` and `1/h`: `s = norm/h · f'(q) / r`. A shape whose `f'(q)/q` has a
    /// closed form overrides this to skip the division (Wendland C2).
    #[inline(always)]
    fn grad_factor(q: f64, r: f64, norm: f64, inv_h: f64) -> f64 {
        norm * inv_h * Self::df(q) / r
    }
}

/// A radial kernel of shape `S` in dimension `D`: holds `h`, `1/h`, the support `SUPPORT·h` and
/// `σ_D/h^D`, and returns exact zeros beyond the support.
#[derive(Clone, Copy)]
pub struct Radial<D: Dim, S: Shape> {
    h: f64,
    inv_h: f64,
    support: f64,
    /// `σ_D / h^D`.
    norm: f64,
    _marker: PhantomData<(D, S)>,
}

impl<D: Dim, S: Shape> fmt::Debug for Radial<D, S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let shape = std::any::type_name::<S>()
            .rsplit("::")
            .next()
            .unwrap_or("?");
        write!(f, "{shape}<{}>(h = {})", D::NAME, self.h)
    }
}

impl<D: Dim, S: Shape> Radial<D, S> {
    /// Support radius in units of `h`.
    pub const SUPPORT: f64 = S::SUPPORT;

    /// Dimensionless normalisation `σ_D`.
    pub fn sigma() -> f64 {
        S::sigma(D::DIM)
    }

    /// The kernel with smoothing length `h > 0`.
    pub fn new(h: f64) -> Self {
        Self {
            h,
            inv_h: 1.0 / h,
            support: S::SUPPORT * h,
            norm: S::sigma(D::DIM) / h.powi(D::DIM as i32),
            _marker: PhantomData,
        }
    }
}

impl<D: Dim, S: Shape> Kernel<D> for Radial<D, S> {
    #[inline(always)]
    fn h(&self) -> f64 {
        self.h
    }
    #[inline(always)]
    fn support_radius(&self) -> f64 {
        self.support
    }
    fn second_moment(&self) -> f64 {
        S::second_moment(D::DIM) * self.h * self.h
    }
    #[inline(always)]
    fn w(&self, r: f64) -> f64 {
        // The polynomial evaluated first and then selected (not a branch around it), so a
        // loop over pairs can run several at once in vector registers.
        let w = self.norm * S::f(r * self.inv_h);
        if r >= self.support { 0.0 } else { w }
    }
    #[inline(always)]
    fn dw_dr(&self, r: f64) -> f64 {
        if r >= self.support {
            0.0
        } else {
            self.norm * self.inv_h * S::df(r * self.inv_h)
        }
    }
    #[inline(always)]
    fn grad_factor_at(&self, r: f64) -> f64 {
        // Evaluated, then selected (as in `w`); a value computed at r = 0 (a division by zero
        // in shapes whose factor divides by r) is discarded.
        let g = S::grad_factor(r * self.inv_h, r, self.norm, self.inv_h);
        if (r > 0.0) & (r < self.support) {
            g
        } else {
            0.0
        }
    }
}
