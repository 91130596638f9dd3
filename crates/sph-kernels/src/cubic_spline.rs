use crate::radial::{Radial, Shape};

/// Cubic (M4) spline kernel (Monaghan & Lattanzio 1985), support `2h`:
///
/// ```text
/// W(q) = σ_D / h^D · { 1 − 3q²/2 + 3q³/4   0 ≤ q < 1
///                      (2 − q)³ / 4        1 ≤ q < 2 }
/// ```
///
/// σ₂ = 10/(7π), σ₃ = 1/π.
pub type CubicSpline<D> = Radial<D, Cubic>;

/// Shape of [`CubicSpline`].
#[derive(Clone, Copy, Debug)]
pub struct Cubic;

impl Shape for Cubic {
    const SUPPORT: f64 = 2.0;
    fn sigma(dim: usize) -> f64 {
        use std::f64::consts::PI;
        match dim {
            2 => 10.0 / (7.0 * PI),
            _ => 1.0 / PI,
        }
    }
    fn second_moment(dim: usize) -> f64 {
        match dim {
            2 => 31.0 / 49.0,
            _ => 9.0 / 10.0,
        }
    }
    #[inline(always)]
    fn f(q: f64) -> f64 {
        if q < 1.0 {
            1.0 - 1.5 * q * q + 0.75 * q * q * q
        } else {
            0.25 * (2.0 - q).powi(3)
        }
    }
    #[inline(always)]
    fn df(q: f64) -> f64 {
        if q < 1.0 {
            -3.0 * q + 2.25 * q * q
        } else {
            -0.75 * (2.0 - q).powi(2)
        }
    }
}
