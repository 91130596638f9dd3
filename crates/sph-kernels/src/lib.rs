//! # sph-kernels
//!
//! SPH smoothing kernels `W(r, h)` in 2D and 3D, with `dW/dr` and `∇W`.
//!
//! | kernel | support | 2D σ | 3D σ | reference |
//! |---|---|---|---|---|
//! | [`QuinticSpline`] | 3h | 7/(478π) | 1/(120π) | Morris et al. 1997; paper Eq. 27 |
//! | [`WendlandC2`] | 2h | 7/(4π) | 21/(16π) | Wendland 1995; paper Eq. 28 |
//! | [`CubicSpline`] | 2h | 10/(7π) | 1/π | Monaghan & Lattanzio 1985 |
//!
//! **The paper's 3D quintic constant is wrong.** Nair & Tomar (2015, below Eq. 27) print
//! α₃ = 3/(359π) ≈ 2.6600e-3; the exact normalisation is 1/(120π) ≈ 2.6526e-3 (0.28 % smaller).
//! The tests of the `quintic_spline` module integrate the kernel numerically and fail with the printed value.
//!
//! Start with the [`Kernel`] trait; pick a kernel at run time with [`KernelKind`] and
//! [`AnyKernel`]. Each kernel is a [`Radial`] kernel of a dimensionless [`Shape`] (support,
//! normalisation, polynomial); adding a kernel means adding a `Shape`. Kernels hold their smoothing length and normalisation in `&self` and are cheap
//! to copy.

mod any_kernel;
mod cubic_spline;
mod kernel;
mod quintic_spline;
mod radial;
#[cfg(test)]
mod tests;
mod wendland_c2;

pub use any_kernel::{AnyKernel, KernelKind};
pub use cubic_spline::{Cubic, CubicSpline};
pub use kernel::Kernel;
pub use quintic_spline::{Quintic, QuinticSpline};
pub use radial::{Radial, Shape};
pub use wendland_c2::{Wendland, WendlandC2};
