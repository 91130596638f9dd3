use crate::kernel::{Kernel, inv_h_pow};
use sph_core::Dim;
use std::marker::PhantomData;

/// Wendland C2 kernel (Wendland 1995), support `2h` — paper Eq. (28):
///
/// ```text
/// W(q) = σ_D / h^D · (1 − q/2)⁴ (2q + 1),   0 ≤ q < 2,   q = r/h
/// ```
///
/// σ₂ = 7/(4π), σ₃ = 21/(16π), as printed in the paper (the normalisation tests confirm both).
#[derive(Clone, Copy, Debug)]
pub struct WendlandC2<D: Dim> {
    h: f64,
    inv_h: f64,
    support: f64,
    norm: f64,
    _dim: PhantomData<D>,
}

impl<D: Dim> WendlandC2<D> {
    /// Support radius in units of `h`.
    pub const SUPPORT: f64 = 2.0;

    /// Dimensionless normalisation σ_D.
    pub fn sigma() -> f64 {
        use std::f64::consts::PI;
        match D::DIM {
            2 => 7.0 / (4.0 * PI),
            _ => 21.0 / (16.0 * PI),
        }
    }

    /// A Wendland C2 kernel with smoothing length `h > 0`.
    pub fn new(h: f64) -> Self {
        Self {
            h,
            inv_h: 1.0 / h,
            support: Self::SUPPORT * h,
            norm: Self::sigma() * inv_h_pow::<D>(h),
            _dim: PhantomData,
        }
    }
}

impl<D: Dim> Kernel<D> for WendlandC2<D> {
    #[inline(always)]
    fn h(&self) -> f64 {
        self.h
    }
    #[inline(always)]
    fn support_radius(&self) -> f64 {
        self.support
    }
    #[inline(always)]
    fn w(&self, r: f64) -> f64 {
        if r >= self.support {
            return 0.0;
        }
        let q = r * self.inv_h;
        let t = (1.0 - 0.5 * q).max(0.0);
        let t2 = t * t;
        self.norm * t2 * t2 * (2.0 * q + 1.0)
    }
    #[inline(always)]
    fn dw_dr(&self, r: f64) -> f64 {
        if r >= self.support {
            return 0.0;
        }
        // d/dq [(1 − q/2)⁴ (2q + 1)] = −5 q (1 − q/2)³.
        let q = r * self.inv_h;
        let t = (1.0 - 0.5 * q).max(0.0);
        -5.0 * self.norm * self.inv_h * q * t * t * t
    }
}
