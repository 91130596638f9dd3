use crate::kernel::{Kernel, inv_h_pow};
use sph_core::Dim;
use std::marker::PhantomData;

/// Quintic spline kernel (Morris, Fox & Zhu 1997), support `3h` — paper Eq. (27):
///
/// ```text
/// W(q) = σ_D / h^D · { (3−q)⁵ − 6(2−q)⁵ + 15(1−q)⁵   0 ≤ q < 1
///                      (3−q)⁵ − 6(2−q)⁵              1 ≤ q < 2
///                      (3−q)⁵                        2 ≤ q < 3 },   q = r/h
/// ```
///
/// σ₂ = 7/(478π) as printed in the paper. σ₃ = 1/(120π): the paper prints 3/(359π), which
/// makes `∫W dV = 1.0028`; the normalisation test integrates the kernel and rejects it.
#[derive(Clone, Copy, Debug)]
pub struct QuinticSpline<D: Dim> {
    h: f64,
    inv_h: f64,
    support: f64,
    /// σ_D / h^D.
    norm: f64,
    _dim: PhantomData<D>,
}

impl<D: Dim> QuinticSpline<D> {
    /// Support radius in units of `h`.
    pub const SUPPORT: f64 = 3.0;

    /// Dimensionless normalisation σ_D.
    pub fn sigma() -> f64 {
        use std::f64::consts::PI;
        match D::DIM {
            2 => 7.0 / (478.0 * PI),
            // Paper (below Eq. 27): 3/(359π) — off by 0.28 %, see the type docs.
            _ => 1.0 / (120.0 * PI),
        }
    }

    /// A quintic spline with smoothing length `h > 0`.
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

impl<D: Dim> Kernel<D> for QuinticSpline<D> {
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
        let t3 = (3.0 - q).max(0.0);
        let t2 = (2.0 - q).max(0.0);
        let t1 = (1.0 - q).max(0.0);
        let p5 = |t: f64| {
            let t2 = t * t;
            t2 * t2 * t
        };
        self.norm * (p5(t3) - 6.0 * p5(t2) + 15.0 * p5(t1))
    }
    #[inline(always)]
    fn dw_dr(&self, r: f64) -> f64 {
        if r >= self.support {
            return 0.0;
        }
        let q = r * self.inv_h;
        let t3 = (3.0 - q).max(0.0);
        let t2 = (2.0 - q).max(0.0);
        let t1 = (1.0 - q).max(0.0);
        let p4 = |t: f64| {
            let t2 = t * t;
            t2 * t2
        };
        -5.0 * self.norm * self.inv_h * (p4(t3) - 6.0 * p4(t2) + 15.0 * p4(t1))
    }
}
