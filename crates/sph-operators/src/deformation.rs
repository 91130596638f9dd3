use crate::context::{SphContext, gather};
use crate::divergence::raw_velocity_gradient;
use sph_core::{Dim, MatrixOps};
use sph_kernels::Kernel;

/// Velocity gradient tensor `G_i`, `(G_i)_kl ≈ ∂u_k/∂x_l`:
///
/// ```text
/// G_i = Σ_j V_j (u_j − u_i) ⊗ ∇̃W_ij = M_i L_iᵀ,    M_i = Σ_j V_j (u_j − u_i) ⊗ ∇W_ij
/// ```
///
/// This is the displacement-gradient term of paper Eq. (26) applied to `u` (the paper writes the
/// transpose, `∂u_l/∂x_k`; the determinant and `cof(A):H` for symmetric `H` are the same either
/// way).
///
/// Computed for the first `out.len()` particles (all of them, or a prefix: see the crate
/// docs).
pub fn velocity_gradient<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    u: &[D::Vector],
    corrections: Option<&[D::Matrix]>,
    out: &mut [D::Matrix],
) {
    assert_eq!(u.len(), ctx.len());
    assert!(out.len() <= ctx.len(), "at most one output per particle");
    gather(out, |i| {
        let m = raw_velocity_gradient(ctx, u, i);
        match corrections {
            Some(l) => m * l[i].transpose(),
            None => m,
        }
    });
}

/// Deformation gradient of a displacement field, paper Eq. (26):
///
/// ```text
/// F_i = I + Σ_j V_j (Δx_j − Δx_i) ⊗ ∇̃W_ij,      (F_i)_kl = δ_kl + ∂Δx_k/∂X_l
/// ```
///
/// with the gradient taken in the reference configuration (the positions of `ctx`). DG-ISPH
/// (Algorithm 1) uses it with `Δx = Δt u*` to form `A = I + ∇(Δt u*)`.
///
/// Computed for the first `out.len()` particles (all of them, or a prefix: see the crate
/// docs).
pub fn deformation_gradient<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    displacements: &[D::Vector],
    corrections: Option<&[D::Matrix]>,
    out: &mut [D::Matrix],
) {
    velocity_gradient(ctx, displacements, corrections, out);
    for f in out.iter_mut() {
        *f += D::Matrix::IDENTITY;
    }
}

/// Principal invariants of a tensor `G` (paper Eqs. 7–8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Invariants {
    /// `I1 = tr G`.
    pub i1: f64,
    /// `I2 = ½((tr G)² − tr(G²))` (in 2D this equals `det G`).
    pub i2: f64,
    /// `I3 = det G` in 3D, 0 in 2D.
    pub i3: f64,
}

/// Principal invariants of `G`, so that `det(I + Δt G) = 1 + Δt I1 + Δt² I2 + Δt³ I3` in 3D and
/// `1 + Δt I1 + Δt² I2` in 2D (Cayley–Hamilton; paper Eqs. 7 and 8).
pub fn invariants<D: Dim>(g: &D::Matrix) -> Invariants {
    let tr = g.trace();
    let tr_sq = (*g * *g).trace();
    Invariants {
        i1: tr,
        i2: 0.5 * (tr * tr - tr_sq),
        i3: if D::DIM == 3 { g.determinant() } else { 0.0 },
    }
}
