//! Particle-shifting concentration gradient (Lind et al. 2012).

use crate::context::{MIN_LEN, Pair, SphContext, gather};
use rayon::prelude::*;
use sph_core::{Dim, MatrixOps, VectorOps};
use sph_kernels::Kernel;

/// Gradient of the particle concentration with the anti-clumping term of Lind, Xu, Stansby &
/// Rogers (2012), J. Comput. Phys. 231, 1499, Eq. (9):
///
/// ```text
/// ∇C_i = Σ_j V_j (1 + R (W_ij / W(Δp))ⁿ) ∇W_ij,    R = 0.2, n = 4
/// ```
///
/// with `Δp` the initial particle spacing. On a uniform lattice it vanishes (by symmetry);
/// it points towards crowded regions, so the shift `δr = −D ∇C` moves particles into voids.
pub fn concentration_gradient<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    spacing: f64,
    out: &mut [D::Vector],
) {
    assert_eq!(out.len(), ctx.len());
    let inv_w_dp = inverse_w_dp(ctx, spacing);
    gather(out, |i| {
        let mut g = D::Vector::ZERO;
        ctx.for_each_pair(i, |p| {
            if p.j != i {
                g += concentration_term(ctx, &p, inv_w_dp);
            }
        });
        g
    });
}

/// One pair's term of [`concentration_gradient`] (`W_ij` from [`SphContext::w_of`];
/// `inv_w_dp` from [`inverse_w_dp`]).
#[inline(always)]
fn concentration_term<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    p: &Pair<D::Vector>,
    inv_w_dp: f64,
) -> D::Vector {
    const R: f64 = 0.2;
    let ratio = ctx.w_of(p) * inv_w_dp;
    let r2 = ratio * ratio;
    p.grad_w * (ctx.volumes[p.j] * (1.0 + R * r2 * r2))
}

/// `1/W(Δp)`, or 0 when the kernel vanishes at the spacing (no anti-clumping term then): the
/// pairs multiply by it instead of each dividing by `W(Δp)`.
fn inverse_w_dp<D: Dim, K: Kernel<D>>(ctx: &SphContext<'_, D, K>, spacing: f64) -> f64 {
    let w_dp = ctx.kernel.w(spacing);
    if w_dp > 0.0 { 1.0 / w_dp } else { 0.0 }
}

/// What a shifting step needs in one pass over the pairs, each pair's kernel gradient
/// evaluated once: `grad_c` = [`concentration_gradient`] and `grad_u` =
/// [`velocity_gradient`](crate::velocity_gradient) of `u` (renormalised with `corrections`
/// when given), bitwise equal to the two separate passes.
///
/// Computed for the first `grad_c.len()` particles (`grad_u` as long; all of them, or a
/// prefix: see the crate docs).
pub fn shifting_gradients<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    spacing: f64,
    u: &[D::Vector],
    corrections: Option<&[D::Matrix]>,
    grad_c: &mut [D::Vector],
    grad_u: &mut [D::Matrix],
) {
    assert_eq!(u.len(), ctx.len());
    assert!(grad_c.len() <= ctx.len(), "at most one output per particle");
    assert_eq!(grad_u.len(), grad_c.len());
    let inv_w_dp = inverse_w_dp(ctx, spacing);
    grad_c
        .par_iter_mut()
        .zip(grad_u.par_iter_mut())
        .enumerate()
        .with_min_len(MIN_LEN)
        .for_each(|(i, (gc, gu))| {
            let ui = u[i];
            let mut c = D::Vector::ZERO;
            let mut m = D::Matrix::ZERO;
            ctx.for_each_pair(i, |p| {
                m += D::Matrix::outer(u[p.j] - ui, p.grad_w * ctx.volumes[p.j]);
                if p.j != i {
                    c += concentration_term(ctx, &p, inv_w_dp);
                }
            });
            *gc = c;
            *gu = match corrections {
                Some(l) => m * l[i].transpose(),
                None => m,
            };
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::Lattice;
    use crate::velocity_gradient;
    use sph_kernels::KernelKind;

    sph_core::dim_tests! {
        fn fused_shifting_gradients_equal_the_separate_passes_bitwise<D>() {
            let lat = Lattice::<D>::new(KernelKind::WendlandC2, 1.3, 0.2);
            let n = lat.len();
            let u: Vec<D::Vector> = lat
                .positions
                .iter()
                .map(|x| D::Vector::from_fn(|k| (3.0 * x.get(k) + k as f64).sin()))
                .collect();
            let l: Vec<D::Matrix> = (0..n)
                .map(|i| D::Matrix::from_fn(|r, c| if r == c { 1.0 + 0.01 * (i % 7) as f64 } else { 0.003 }))
                .collect();
            lat.with_ctx(|ctx| {
                for corrections in [None, Some(&l[..])] {
                    let (mut c1, mut c2) = (vec![D::Vector::ZERO; n], vec![D::Vector::ZERO; n]);
                    let (mut g1, mut g2) = (vec![D::Matrix::ZERO; n], vec![D::Matrix::ZERO; n]);
                    concentration_gradient(ctx, lat.dx, &mut c1);
                    velocity_gradient(ctx, &u, corrections, &mut g1);
                    shifting_gradients(ctx, lat.dx, &u, corrections, &mut c2, &mut g2);
                    assert!(c1 == c2, "concentration gradients differ");
                    assert!(g1 == g2, "velocity gradients differ");
                    assert!(c1.iter().any(|v| v.length() > 0.0), "a jittered lattice has a concentration gradient");
                }
            });
        }
    }
}
