//! A Hessian that is exact for quadratic fields on any non-degenerate particle cloud.

use crate::context::{MIN_LEN, SphContext};
use crate::hessian::eq25_stencil;
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
/// "renormalised" Hessian in the sense of the Taylor-series SPH corrections):
///
/// ```text
/// minimise Σ_j V_j W_ij ( f_j − f_i − g·y_ij − ½ y_ijᵀ H y_ij )²,    y_ij = x_j − x_i
/// ```
///
/// The normal equations `M θ = Σ_j w_j φ_j (f_j − f_i)` have `d + d(d+1)/2` unknowns (5 in 2D,
/// 9 in 3D) and are solved per particle by Gaussian elimination with partial pivoting on the
/// `h`-scaled monomials `φ`. The result is exact for every quadratic field wherever the
/// neighbourhood spans the quadratics. Where it does not (a pivot below `1e-10` of the largest
/// diagonal, e.g. a sparse free surface), the particle falls back to the Eq. 25
/// [`hessian`](crate::hessian), and is counted.
pub fn hessian_quadratic_fit<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    f: &[f64],
    out: &mut [D::Matrix],
) -> QuadraticFitStats {
    assert_eq!(f.len(), ctx.len());
    assert_eq!(out.len(), ctx.len());
    let fallbacks = out
        .par_iter_mut()
        .enumerate()
        .with_min_len(MIN_LEN)
        .map(|(i, out_i)| {
            let row = ctx.neighbors.row(i);
            let mut h = D::Matrix::ZERO;
            let fit = hessian_stencil_fit(ctx, i, |k, c| h += c * (f[row[k] as usize] - f[i]));
            *out_i = h;
            usize::from(!fit)
        })
        .sum();
    QuadraticFitStats { fallbacks }
}

/// The least-squares Hessian as a stencil: calls `emit(k, C_ij)` for the `k`-th neighbour `j`
/// of particle `i`, with `(∇∇f)_i = Σ_j C_ij (f_j − f_i)` exact for quadratic `f`. Returns
/// `false` (after emitting the Eq. 25 stencil instead) if the fit is singular.
pub fn hessian_stencil_fit<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    i: usize,
    mut emit: impl FnMut(usize, D::Matrix),
) -> bool {
    let d = D::DIM;
    let n = d + D::SYM;
    let inv_h = 1.0 / ctx.kernel.h();
    let xi = ctx.positions[i];
    let mut m = [0.0; MAX_N * MAX_N];
    let mut phi = [0.0; MAX_N];
    for j in ctx.neighbors_of(i) {
        let y = -ctx.pair(xi, j);
        let w = ctx.volumes[j] * ctx.kernel.w(y.length());
        if j == i || w == 0.0 {
            continue;
        }
        monomials::<D>(y * inv_h, &mut phi);
        for r in 0..n {
            for c in r..n {
                m[r * MAX_N + c] += w * phi[r] * phi[c];
            }
        }
    }
    for r in 0..n {
        for c in 0..r {
            m[r * MAX_N + c] = m[c * MAX_N + r];
        }
    }
    // Rows d..n of M⁻¹ map the weighted monomials of a pair to its Hessian coefficients.
    let Some(minv) = invert(&m, n) else {
        eq25_stencil(ctx, i, (D::DIM + 2) as f64, &mut emit);
        return false;
    };
    for (k, j) in ctx.neighbors_of(i).enumerate() {
        let y = -ctx.pair(xi, j);
        let w = ctx.volumes[j] * ctx.kernel.w(y.length());
        if j == i || w == 0.0 {
            continue;
        }
        monomials::<D>(y * inv_h, &mut phi);
        let mut coef = [0.0; MAX_N];
        for r in d..n {
            coef[r - d] = w * (0..n).map(|c| minv[r * MAX_N + c] * phi[c]).sum::<f64>();
        }
        emit(k, hessian_from_coefficients::<D>(&coef, inv_h * inv_h));
    }
    true
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

/// Hessian from the fitted (h-scaled) quadratic coefficients `[H_11 .. H_dd, H_12, ..]`.
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

/// Inverse of the leading `n × n` block by Gauss–Jordan elimination with partial pivoting;
/// `None` if a pivot falls below `1e-10` of the largest diagonal entry.
fn invert(m: &[f64; MAX_N * MAX_N], n: usize) -> Option<[f64; MAX_N * MAX_N]> {
    let scale = (0..n).map(|k| m[k * MAX_N + k].abs()).fold(0.0, f64::max);
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    let mut a = *m;
    let mut inv = [0.0; MAX_N * MAX_N];
    for k in 0..n {
        inv[k * MAX_N + k] = 1.0;
    }
    for col in 0..n {
        let piv = (col..n).max_by(|&p, &q| {
            a[p * MAX_N + col]
                .abs()
                .total_cmp(&a[q * MAX_N + col].abs())
        })?;
        if a[piv * MAX_N + col].abs() < 1e-10 * scale {
            return None;
        }
        if piv != col {
            for c in 0..n {
                a.swap(piv * MAX_N + c, col * MAX_N + c);
                inv.swap(piv * MAX_N + c, col * MAX_N + c);
            }
        }
        let p = 1.0 / a[col * MAX_N + col];
        for c in 0..n {
            a[col * MAX_N + c] *= p;
            inv[col * MAX_N + c] *= p;
        }
        for r in 0..n {
            let factor = a[r * MAX_N + col];
            if r != col && factor != 0.0 {
                for c in 0..n {
                    a[r * MAX_N + c] -= factor * a[col * MAX_N + c];
                    inv[r * MAX_N + c] -= factor * inv[col * MAX_N + c];
                }
            }
        }
    }
    Some(inv)
}
