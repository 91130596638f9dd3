use crate::context::{SphContext, gather};
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;

/// Free-surface indicator, the SPH divergence of the position vector (Lee et al. 2008; used by
/// the free-surface model of Nair & Tomar 2014, the paper's Ref. [17]):
///
/// ```text
/// ∇·r_i = Σ_j V_j (x_j − x_i)·∇W_ij
/// ```
///
/// It is ≈ `d` in the bulk (2 in 2D, 3 in 3D, to the kernel's lattice-sum error) and drops to
/// about half that at a free surface, where the kernel support is truncated. Particles below a
/// threshold are treated as free-surface particles (Dirichlet `p = 0`) by the pressure solver.
pub fn free_surface_indicator<D: Dim, K: Kernel<D>>(ctx: &SphContext<'_, D, K>, out: &mut [f64]) {
    assert_eq!(out.len(), ctx.len());
    gather(out, |i| {
        let xi = ctx.positions[i];
        let mut s = 0.0;
        for j in ctx.neighbors_of(i) {
            let x_ij = ctx.pair(xi, j);
            s -= ctx.volumes[j] * x_ij.dot(ctx.kernel.grad_w(x_ij));
        }
        s
    });
}
