use crate::context::{SphContext, gather, pair_f_of};
use sph_core::Dim;
use sph_kernels::Kernel;

/// Morris (1997) Laplacian of a scalar field, the left-hand side of the PPE (paper Eq. 3):
///
/// ```text
/// ∇²f_i = 2 Σ_j V_j (f_i − f_j) F_ij,     F_ij = x_ij·∇W_ij / (r_ij² + η²),  η = 0.01 h
/// ```
///
/// `F_ij ≤ 0`, so the operator is a negative-semidefinite graph Laplacian. It equals the trace of
/// [`hessian`](crate::hessian) to round-off (tested).
pub fn laplacian<D: Dim, K: Kernel<D>>(ctx: &SphContext<'_, D, K>, f: &[f64], out: &mut [f64]) {
    assert_eq!(f.len(), ctx.len());
    assert_eq!(out.len(), ctx.len());
    gather(out, |i| {
        let h = ctx.kernel.h();
        let mut s = 0.0;
        ctx.for_each_pair(i, |p| {
            s += ctx.volumes[p.j] * (f[i] - f[p.j]) * pair_f_of::<D>(p.x_ij, p.grad_w, h);
        });
        2.0 * s
    });
}
