//! A Hessian that is exact for quadratic fields on any non-degenerate particle cloud.

use crate::context::{MIN_LEN, SphContext};
use crate::hessian::hessian;
use rayon::prelude::*;
use sph_core::{Dim, MatrixOps, VectorOps};
use sph_kernels::Kernel;

/// Outcome of [`hessian_quadratic_fit`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QuadraticFitStats {
    /// Particles whose moment matrix was (near-)singular and got the Eq. 25 Hessian instead.
    pub fallbacks: usize,
}

/// Largest number of unknowns: 3 gradient + 6 Hessian components in 3D.
const MAX_N: usize = 9;

/// Gradient and Hessian by kernel-weighted least squares (a second-order consistent,
/// "renormalised" Hessian in the sense of the MLS/Taylor-series SPH corrections):
///
/// ```text
/// minimise Σ_j V_j W_ij ( f_j − f_i − g·y_ij − ½ y_ijᵀ H y_ij )²,    y_ij = x_j − x_i
/// ```
///
/// The normal equations have `d + d(d+1)/2` unknowns (5 in 2D, 9 in 3D), solved per particle by
/// Gaussian elimination with partial pivoting on the `h`-scaled monomials. The result is exact
/// for every quadratic field wherever the neighbourhood spans the quadratics (any interior
/// particle). Where it does not (a pivot below `1e-10` of the largest diagonal, e.g. a sparse free
/// surface), the particle falls back to [`hessian`] (paper Eq. 25) and is counted.
pub fn hessian_quadratic_fit<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    f: &[f64],
    out: &mut [D::Matrix],
) -> QuadraticFitStats {
    assert_eq!(f.len(), ctx.len());
    assert_eq!(out.len(), ctx.len());
    let d = D::DIM;
    let n = d + D::SYM;
    let inv_h = 1.0 / ctx.kernel.h();
    let fallbacks = out
        .par_iter_mut()
        .enumerate()
        .with_min_len(MIN_LEN)
        .map(|(i, out_i)| {
            let xi = ctx.positions[i];
            let mut m = [0.0; MAX_N * MAX_N];
            let mut b = [0.0; MAX_N];
            let mut phi = [0.0; MAX_N];
            for j in ctx.neighbors_of(i) {
                if j == i {
                    continue;
                }
                let y = (ctx.positions[j] - xi) * inv_h;
                let w = ctx.volumes[j] * ctx.kernel.w((ctx.positions[j] - xi).length());
                if w == 0.0 {
                    continue;
                }
                monomials::<D>(y, &mut phi);
                let df = f[j] - f[i];
                for r in 0..n {
                    let wr = w * phi[r];
                    b[r] += wr * df;
                    for c in r..n {
                        m[r * MAX_N + c] += wr * phi[c];
                    }
                }
            }
            for r in 0..n {
                for c in 0..r {
                    m[r * MAX_N + c] = m[c * MAX_N + r];
                }
            }
            match solve(&mut m, &mut b, n) {
                Some(()) => {
                    *out_i = hessian_from_coefficients::<D>(&b[d..n], inv_h * inv_h);
                    0
                }
                None => {
                    // Marked for the fallback below.
                    *out_i = D::Matrix::from_fn(|_, _| f64::NAN);
                    1
                }
            }
        })
        .sum::<usize>();
    if fallbacks > 0 {
        // Rare path (free-surface particles with one-sided neighbourhoods): patch the marked
        // particles with the Eq. 25 Hessian.
        let mut plain = vec![D::Matrix::ZERO; ctx.len()];
        hessian(ctx, f, &mut plain);
        for (o, p) in out.iter_mut().zip(&plain) {
            if !o.is_finite() {
                *o = *p;
            }
        }
    }
    QuadraticFitStats { fallbacks }
}

/// Monomials `[y_1 .. y_d, ½y_1², .., ½y_d², y_1 y_2, (y_1 y_3, y_2 y_3)]`, whose coefficients are
/// `[g, H_11 .. H_dd, H_12, (H_13, H_23)]`.
#[inline(always)]
fn monomials<D: Dim>(y: D::Vector, phi: &mut [f64; MAX_N]) {
    let d = D::DIM;
    for k in 0..d {
        phi[k] = y.get(k);
        phi[d + k] = 0.5 * y.get(k) * y.get(k);
    }
    let mut at = 2 * d;
    for k in 0..d {
        for l in k + 1..d {
            phi[at] = y.get(k) * y.get(l);
            at += 1;
        }
    }
}

/// Hessian from the fitted (h-scaled) quadratic coefficients.
fn hessian_from_coefficients<D: Dim>(c: &[f64], inv_h2: f64) -> D::Matrix {
    let d = D::DIM;
    let mut h = D::Matrix::ZERO;
    for k in 0..d {
        h.set(k, k, c[k] * inv_h2);
    }
    let mut at = d;
    for k in 0..d {
        for l in k + 1..d {
            h.set(k, l, c[at] * inv_h2);
            h.set(l, k, c[at] * inv_h2);
            at += 1;
        }
    }
    h
}

/// Solves `m x = b` in place (`x` returned in `b`) by Gaussian elimination with partial pivoting;
/// `None` if a pivot falls below `1e-10` of the largest diagonal entry.
fn solve(m: &mut [f64; MAX_N * MAX_N], b: &mut [f64; MAX_N], n: usize) -> Option<()> {
    let scale = (0..n).map(|k| m[k * MAX_N + k].abs()).fold(0.0, f64::max);
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    for col in 0..n {
        let piv = (col..n).max_by(|&a, &c| {
            m[a * MAX_N + col]
                .abs()
                .total_cmp(&m[c * MAX_N + col].abs())
        })?;
        if m[piv * MAX_N + col].abs() < 1e-10 * scale {
            return None;
        }
        if piv != col {
            for c in 0..n {
                m.swap(piv * MAX_N + c, col * MAX_N + c);
            }
            b.swap(piv, col);
        }
        let inv = 1.0 / m[col * MAX_N + col];
        for r in col + 1..n {
            let factor = m[r * MAX_N + col] * inv;
            if factor != 0.0 {
                for c in col..n {
                    m[r * MAX_N + c] -= factor * m[col * MAX_N + c];
                }
                b[r] -= factor * b[col];
            }
        }
    }
    for r in (0..n).rev() {
        let mut s = b[r];
        for c in r + 1..n {
            s -= m[r * MAX_N + c] * b[c];
        }
        b[r] = s / m[r * MAX_N + r];
    }
    Some(())
}
