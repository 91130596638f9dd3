use crate::radial::{Radial, Shape};

/// Wendland C2 kernel (Wendland 1995), support `2h` — paper Eq. (28):
///
/// ```text
/// W(q) = σ_D / h^D · (1 − q/2)⁴ (2q + 1),   0 ≤ q < 2,   q = r/h
/// ```
///
/// σ₂ = 7/(4π), σ₃ = 21/(16π), as printed in the paper (the normalisation tests confirm both).
pub type WendlandC2<D> = Radial<D, Wendland>;

/// Shape of [`WendlandC2`].
#[derive(Clone, Copy, Debug)]
pub struct Wendland;

impl Shape for Wendland {
    const SUPPORT: f64 = 2.0;
    fn sigma(dim: usize) -> f64 {
        use std::f64::consts::PI;
        match dim {
            2 => 7.0 / (4.0 * PI),
            _ => 21.0 / (16.0 * PI),
        }
    }
    fn second_moment(dim: usize) -> f64 {
        match dim {
            2 => 5.0 / 9.0,
            _ => 4.0 / 5.0,
        }
    }
    #[inline(always)]
    fn f(q: f64) -> f64 {
        (1.0 - 0.5 * q).powi(4) * (2.0 * q + 1.0)
    }
    #[inline(always)]
    fn df(q: f64) -> f64 {
        // d/dq [(1 − q/2)⁴ (2q + 1)] = −5 q (1 − q/2)³.
        -5.0 * q * (1.0 - 0.5 * q).powi(3)
    }
    #[inline(always)]
    fn grad_factor(q: f64, _r: f64, norm: f64, inv_h: f64) -> f64 {
        // Of Eq. (28)'s kernel: (dW/dr)/r = σ_D/h^D · f'(q)/(h r) = σ_D/h^(D+2) · (−5 (1 − q/2)³),
        // since r = q h: no division.
        norm * inv_h * inv_h * (-5.0 * (1.0 - 0.5 * q).powi(3))
    }
}
