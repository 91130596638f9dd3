use crate::context::{SphContext, gather, pair_f};
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
        let xi = ctx.positions[i];
        let mut s = 0.0;
        for j in ctx.neighbors_of(i) {
            s += ctx.volumes[j] * (f[i] - f[j]) * pair_f::<D, K>(ctx.kernel, ctx.pair(xi, j));
        }
        2.0 * s
    });
}
