//! Particle-shifting concentration gradient (Lind et al. 2012).

use crate::context::{SphContext, gather};
use sph_core::{Dim, VectorOps};
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
    const R: f64 = 0.2;
    assert_eq!(out.len(), ctx.len());
    let w_dp = ctx.kernel.w(spacing);
    gather(out, |i| {
        let xi = ctx.positions[i];
        let mut g = D::Vector::ZERO;
        for j in ctx.neighbors_of(i) {
            if j == i {
                continue;
            }
            let x_ij = ctx.pair(xi, j);
            let ratio = if w_dp > 0.0 {
                ctx.kernel.w(x_ij.length()) / w_dp
            } else {
                0.0
            };
            let r2 = ratio * ratio;
            g += ctx.kernel.grad_w(x_ij) * (ctx.volumes[j] * (1.0 + R * r2 * r2));
        }
        g
    });
}
