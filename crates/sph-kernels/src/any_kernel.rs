use crate::{CubicSpline, Kernel, QuinticSpline, WendlandC2};
use serde::{Deserialize, Serialize};
use sph_core::Dim;

/// Kernel choice as written in a scene file: `kernel = "quintic_spline"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KernelKind {
    /// [`QuinticSpline`], support 3h (the paper's choice for the drops).
    QuinticSpline,
    /// [`WendlandC2`], support 2h.
    WendlandC2,
    /// [`CubicSpline`], support 2h.
    CubicSpline,
}

impl KernelKind {
    /// The name as written in scene files and outputs (`quintic_spline`, ...).
    pub fn name(self) -> &'static str {
        match self {
            KernelKind::QuinticSpline => "quintic_spline",
            KernelKind::WendlandC2 => "wendland_c2",
            KernelKind::CubicSpline => "cubic_spline",
        }
    }

    /// Support radius in units of `h`.
    pub fn support_factor(self) -> f64 {
        match self {
            KernelKind::QuinticSpline => 3.0,
            KernelKind::WendlandC2 | KernelKind::CubicSpline => 2.0,
        }
    }

    /// The kernel for dimension `D` with smoothing length `h`.
    pub fn build<D: Dim>(self, h: f64) -> AnyKernel<D> {
        match self {
            KernelKind::QuinticSpline => AnyKernel::QuinticSpline(QuinticSpline::new(h)),
            KernelKind::WendlandC2 => AnyKernel::WendlandC2(WendlandC2::new(h)),
            KernelKind::CubicSpline => AnyKernel::CubicSpline(CubicSpline::new(h)),
        }
    }

    /// All kernels, for tests and reports.
    pub const ALL: [KernelKind; 3] = [
        KernelKind::QuinticSpline,
        KernelKind::WendlandC2,
        KernelKind::CubicSpline,
    ];
}

/// A kernel chosen at run time. The `match` is inlined into pair loops, so this costs a
/// predictable branch, not a virtual call; where a short loop pays even that (it keeps the
/// loop from being compiled as straight-line code), [`with_kernel!`](crate::with_kernel)
/// takes the branch once, outside it.
#[derive(Clone, Copy, Debug)]
pub enum AnyKernel<D: Dim> {
    /// See [`QuinticSpline`].
    QuinticSpline(QuinticSpline<D>),
    /// See [`WendlandC2`].
    WendlandC2(WendlandC2<D>),
    /// See [`CubicSpline`].
    CubicSpline(CubicSpline<D>),
}

impl<D: Dim> Kernel<D> for AnyKernel<D> {
    #[inline(always)]
    fn h(&self) -> f64 {
        crate::with_kernel!(self, k => k.h())
    }
    #[inline(always)]
    fn support_radius(&self) -> f64 {
        crate::with_kernel!(self, k => k.support_radius())
    }
    fn second_moment(&self) -> f64 {
        crate::with_kernel!(self, k => k.second_moment())
    }
    #[inline(always)]
    fn w(&self, r: f64) -> f64 {
        crate::with_kernel!(self, k => k.w(r))
    }
    #[inline(always)]
    fn dw_dr(&self, r: f64) -> f64 {
        crate::with_kernel!(self, k => k.dw_dr(r))
    }
    #[inline(always)]
    fn grad_factor_at(&self, r: f64) -> f64 {
        crate::with_kernel!(self, k => k.grad_factor_at(r))
    }
}

/// Runs `$body` with `$k` bound to the concrete kernel inside an [`AnyKernel`] reference: the
/// kernel is chosen once and `$body` is compiled once per kernel type, so the pair loops in it
/// carry no per-pair branch on the kernel.
///
/// ```
/// use sph_kernels::{Kernel, KernelKind, with_kernel};
/// let any = KernelKind::WendlandC2.build::<sph_core::D2>(0.1);
/// let w0 = with_kernel!(&any, k => k.w(0.0));
/// assert_eq!(w0, any.w(0.0));
/// ```
#[macro_export]
macro_rules! with_kernel {
    ($any:expr, $k:ident => $body:expr) => {
        match $any {
            $crate::AnyKernel::QuinticSpline($k) => $body,
            $crate::AnyKernel::WendlandC2($k) => $body,
            $crate::AnyKernel::CubicSpline($k) => $body,
        }
    };
}
