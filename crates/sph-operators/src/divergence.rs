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
///
/// Computed for the first `out.len()` particles (all of them, or a prefix: see the crate
/// docs).
pub fn divergence<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    u: &[D::Vector],
    corrections: Option<&[D::Matrix]>,
    out: &mut [f64],
) {
    assert_eq!(u.len(), ctx.len());
    assert!(out.len() <= ctx.len(), "at most one output per particle");
    match corrections {
        None => gather(out, |i| {
            let ui = u[i];
            let mut s = 0.0;
            ctx.for_each_pair(i, |p| {
                s += ctx.volumes[p.j] * (u[p.j] - ui).dot(p.grad_w);
            });
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
    let ui = u[i];
    let mut m = D::Matrix::ZERO;
    ctx.for_each_pair(i, |p| {
        m += D::Matrix::outer(u[p.j] - ui, p.grad_w * ctx.volumes[p.j]);
    });
    m
}
