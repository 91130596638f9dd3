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
/// predictable branch, not a virtual call.
#[derive(Clone, Copy, Debug)]
pub enum AnyKernel<D: Dim> {
    /// See [`QuinticSpline`].
    QuinticSpline(QuinticSpline<D>),
    /// See [`WendlandC2`].
    WendlandC2(WendlandC2<D>),
    /// See [`CubicSpline`].
    CubicSpline(CubicSpline<D>),
}

macro_rules! dispatch {
    ($self:ident, $k:ident => $e:expr) => {
        match $self {
            AnyKernel::QuinticSpline($k) => $e,
            AnyKernel::WendlandC2($k) => $e,
            AnyKernel::CubicSpline($k) => $e,
        }
    };
}

impl<D: Dim> Kernel<D> for AnyKernel<D> {
    #[inline(always)]
    fn h(&self) -> f64 {
        dispatch!(self, k => k.h())
    }
    #[inline(always)]
    fn support_radius(&self) -> f64 {
        dispatch!(self, k => k.support_radius())
    }
    #[inline(always)]
    fn w(&self, r: f64) -> f64 {
        dispatch!(self, k => k.w(r))
    }
    #[inline(always)]
    fn dw_dr(&self, r: f64) -> f64 {
        dispatch!(self, k => k.dw_dr(r))
    }
}
