use crate::kernel::{Kernel, inv_h_pow};
use sph_core::Dim;
use std::marker::PhantomData;

/// Cubic (M4) spline kernel (Monaghan & Lattanzio 1985), support `2h`:
///
/// ```text
/// W(q) = σ_D / h^D · { 1 − 3q²/2 + 3q³/4   0 ≤ q < 1
///                      (2 − q)³ / 4        1 ≤ q < 2 }
/// ```
///
/// σ₂ = 10/(7π), σ₃ = 1/π.
#[derive(Clone, Copy, Debug)]
pub struct CubicSpline<D: Dim> {
    h: f64,
    inv_h: f64,
    support: f64,
    norm: f64,
    _dim: PhantomData<D>,
}

impl<D: Dim> CubicSpline<D> {
    /// Support radius in units of `h`.
    pub const SUPPORT: f64 = 2.0;

    /// Dimensionless normalisation σ_D.
    pub fn sigma() -> f64 {
        use std::f64::consts::PI;
        match D::DIM {
            2 => 10.0 / (7.0 * PI),
            _ => 1.0 / PI,
        }
    }

    /// A cubic spline with smoothing length `h > 0`.
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

impl<D: Dim> Kernel<D> for CubicSpline<D> {
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
        let f = if q < 1.0 {
            1.0 - 1.5 * q * q + 0.75 * q * q * q
        } else if q < 2.0 {
            let t = 2.0 - q;
            0.25 * t * t * t
        } else {
            0.0
        };
        self.norm * f
    }
    #[inline(always)]
    fn dw_dr(&self, r: f64) -> f64 {
        if r >= self.support {
            return 0.0;
        }
        let q = r * self.inv_h;
        let df = if q < 1.0 {
            -3.0 * q + 2.25 * q * q
        } else if q < 2.0 {
            let t = 2.0 - q;
            -0.75 * t * t
        } else {
            0.0
        };
        self.norm * self.inv_h * df
    }
}
