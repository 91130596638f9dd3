use crate::context::{MIN_LEN, SphContext};
use rayon::prelude::*;
use sph_core::{Dim, MatrixOps};
use sph_kernels::Kernel;

/// Outcome of [`correction_matrices`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CorrectionStats {
    /// Particles whose moment matrix was singular or ill-conditioned and got `L_i = I`.
    pub fallbacks: usize,
}

/// Kernel-gradient renormalisation matrices (Bonet & Lok 1999; Randles & Libersky 1996):
///
/// ```text
/// B_i = Σ_j V_j ∇W_ij ⊗ (x_j − x_i),     L_i = B_i⁻¹,     ∇̃W_ij = L_i ∇W_ij
/// ```
///
/// With `∇̃W`, `Σ_j V_j (f_j − f_i) ∇̃W_ij = L_i B_i ∇f = ∇f` exactly for every linear field `f`,
/// whatever the particle arrangement. On a full lattice `B_i ≈ I` (to the lattice-sum error of
/// the kernel); at a free surface it is far from `I` and may be singular or small: where
/// `det B_i < min_det` (relative to the interior value 1), or where the inverse would amplify a
/// gradient by more than `max_gain` (its largest entry in magnitude: a particle with few,
/// distant neighbours, spray ahead of a front, whose `B_i` is small in every direction), the
/// particle falls back to `L_i = I`, and the count is returned. On a flat free surface the
/// gain is about 2.
pub fn correction_matrices<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    min_det: f64,
    max_gain: f64,
    out: &mut [D::Matrix],
) -> CorrectionStats {
    assert_eq!(out.len(), ctx.len());
    let fallbacks = out
        .par_iter_mut()
        .enumerate()
        .with_min_len(MIN_LEN)
        .map(|(i, l)| {
            let mut b = D::Matrix::ZERO;
            ctx.for_each_pair(i, |p| {
                b += D::Matrix::outer(p.grad_w, -p.x_ij) * ctx.volumes[p.j];
            });
            match b
                .try_inverse(min_det)
                .filter(|inv| gain::<D>(inv) <= max_gain)
            {
                Some(inv) => {
                    *l = inv;
                    0
                }
                None => {
                    *l = D::Matrix::IDENTITY;
                    1
                }
            }
        })
        .sum();
    CorrectionStats { fallbacks }
}

/// The largest entry of `m` in magnitude: how much an inverse moment matrix amplifies a
/// gradient (the `max_gain` test of [`correction_matrices`]).
pub(crate) fn gain<D: Dim>(m: &D::Matrix) -> f64 {
    let mut g: f64 = 0.0;
    for r in 0..D::DIM {
        for c in 0..D::DIM {
            g = g.max(m.get(r, c).abs());
        }
    }
    g
}

/// `L_i ∇W_ij` when corrections are given, else `∇W_ij`.
#[inline(always)]
pub(crate) fn corrected<D: Dim>(l: Option<&[D::Matrix]>, i: usize, g: D::Vector) -> D::Vector {
    match l {
        Some(l) => l[i] * g,
        None => g,
    }
}
