use crate::context::{SphContext, gather};
use sph_core::{Dim, MatrixOps, VectorOps};
use sph_kernels::Kernel;

/// Divergence of the vector field `u`, the source term `∇·u*/Δt` of the pressure Poisson
/// equation, paper Eq. (3):
///
/// ```text
/// ∇·u_i = Σ_j V_j (u_j − u_i)·∇̃W_ij,     ∇̃W_ij = L_i ∇W_ij  (or ∇W_ij without corrections)
/// ```
///
/// With corrections it is evaluated as `M_i : L_i`, `M_i = Σ_j V_j (u_j − u_i) ⊗ ∇W_ij`, so the
/// correction costs one contraction per particle instead of a matrix product per pair.
pub fn divergence<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    u: &[D::Vector],
    corrections: Option<&[D::Matrix]>,
    out: &mut [f64],
) {
    assert_eq!(u.len(), ctx.len());
    assert_eq!(out.len(), ctx.len());
    match corrections {
        None => gather(out, |i| {
            let xi = ctx.positions[i];
            let ui = u[i];
            let mut s = 0.0;
            for j in ctx.neighbors_of(i) {
                let g = ctx.kernel.grad_w(ctx.pair(xi, j));
                s += ctx.volumes[j] * (u[j] - ui).dot(g);
            }
            s
        }),
        Some(l) => gather(out, |i| raw_velocity_gradient(ctx, u, i).contract(&l[i])),
    }
}

/// `M_i = Σ_j V_j (u_j − u_i) ⊗ ∇W_ij` (uncorrected velocity gradient, `M_kl ≈ ∂u_k/∂x_l`).
#[inline(always)]
pub(crate) fn raw_velocity_gradient<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    u: &[D::Vector],
    i: usize,
) -> D::Matrix {
    let xi = ctx.positions[i];
    let ui = u[i];
    let mut m = D::Matrix::ZERO;
    for j in ctx.neighbors_of(i) {
        let g = ctx.kernel.grad_w(ctx.pair(xi, j));
        m += D::Matrix::outer(u[j] - ui, g * ctx.volumes[j]);
    }
    m
}
