use crate::context::{SphContext, gather};
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;

/// Free-surface indicator, the SPH divergence of the position vector (Lee et al. 2008; used by
/// the free-surface model of Nair & Tomar 2014, the paper's Ref. \[17\]):
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
        let mut s = 0.0;
        ctx.for_each_pair(i, |p| {
            s -= ctx.volumes[p.j] * p.x_ij.dot(p.grad_w);
        });
        s
    });
}

/// Free-surface scan of Marrone et al. (2010), J. Comput. Phys. 229, 3652 ("umbrella" test),
/// written for 2D and 3D alike: particle `i` is on the free surface when no neighbour covers
/// the region just outside it,
///
/// ```text
/// n_i = −ν_i/|ν_i|,  ν_i = L_i Σ_j V_j ∇W_ij,   T_i = x_i + h n_i,
/// j covers i ⇔ (r_ij ≥ √2 h and |x_j − T_i| < h) or (0 < r_ij < √2 h and angle(n_i, x_j − x_i) < π/4)
/// ```
///
/// (the circle of radius `h` about `T_i` passes through `x_i`; its points nearer than `√2 h` to
/// `x_i` lie inside the cone of half-angle π/4 about `n_i`, which the test uses near `x_i`). The
/// region is empty exactly when nothing lies within about a smoothing length outside `x_i` along
/// its normal, however crowded the particle's neighbourhood is elsewhere — which is where `∇·r`
/// ([`free_surface_indicator`]) can read a surface particle as interior. `corrections` are the
/// renormalisation matrices `L_i` (`None`: `L_i = I`). Writes `true` for surface particles.
pub fn free_surface_scan<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    corrections: Option<&[D::Matrix]>,
    out: &mut [bool],
) {
    assert_eq!(out.len(), ctx.len());
    let h = ctx.kernel.h();
    let sqrt2h = std::f64::consts::SQRT_2 * h;
    let cos45 = std::f64::consts::FRAC_1_SQRT_2;
    gather(out, |i| {
        let xi = ctx.positions[i];
        let mut nu = D::Vector::ZERO;
        ctx.for_each_pair(i, |p| {
            nu += p.grad_w * ctx.volumes[p.j];
        });
        if let Some(l) = corrections {
            nu = l[i] * nu;
        }
        let len = nu.length();
        if len == 0.0 {
            // A perfectly symmetric neighbourhood, or no neighbour at all.
            return ctx.neighbors.row(i).len() <= 1;
        }
        let n = nu * (-1.0 / len);
        let covered = ctx.neighbors_of(i).any(|j| {
            let x_ji = -ctx.pair(xi, j);
            let r = x_ji.length();
            if r == 0.0 {
                false
            } else if r >= sqrt2h {
                (x_ji - n * h).length() < h
            } else {
                x_ji.dot(n) > cos45 * r
            }
        });
        !covered
    });
}
