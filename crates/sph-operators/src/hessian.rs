use crate::context::{SphContext, gather, laplacian_regulariser};
use sph_core::{Dim, MatrixOps, VectorOps};
use sph_kernels::Kernel;

/// Which discrete Hessian to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HessianForm {
    /// Paper Eq. (25) with the coefficient `d + 2` (see [`hessian`]). Its trace is the Morris
    /// Laplacian. On quadratic fields at h = 1.3 dx (3D lattice) its error is 1.6 % (quintic) to
    /// 6.2 % (Wendland C2) of max |H|; per entry it is larger: off-diagonal entries −3.25 % and
    /// −13.1 %, diagonal entries up to −4.9 % and −18.6 % for `H = ((2,1,1),(1,4,1),(1,1,6))` (a
    /// diagonal entry's error mixes in the trace, so it depends on the field; test
    /// `eq25_hessian_entry_errors_3d`).
    #[default]
    Eq25,
    /// Weighted least-squares fit (see [`hessian_quadratic_fit`](crate::hessian_quadratic_fit)):
    /// exact for quadratic fields; falls back to `Eq25` where the fit is singular.
    QuadraticFit,
}

/// Hessian `∇∇f` of a scalar field, paper Eq. (25) with the coefficient corrected for 3D:
///
/// ```text
/// (∇∇f)_i = Σ_j V_j ((d + 2) x_ij⊗x_ij / r_ij² − I) (f_i − f_j) F_ij,
///           F_ij = x_ij·∇W_ij / (r_ij² + (0.01h)²)
/// ```
///
/// The paper prints 4 for `d + 2`; that is right in 2D only. The coefficient follows from the
/// isotropic moments `∫ x_k x_l W'/r dV = −δ_kl` and
/// `∫ x_i x_j x_k x_l W'/r³ dV = −(δ_ij δ_kl + δ_ik δ_jl + δ_il δ_jk)/(d + 2)`, and it makes the
/// trace equal the Morris Laplacian exactly (`(d + 2) − d = 2`), which the tests check to
/// round-off. Not exact for quadratic fields at finite `h/dx` (see
/// [`hessian_quadratic_fit`](crate::hessian_quadratic_fit) for a form that is). Zero-distance
/// pairs are skipped.
pub fn hessian<D: Dim, K: Kernel<D>>(ctx: &SphContext<'_, D, K>, f: &[f64], out: &mut [D::Matrix]) {
    hessian_with_coefficient(ctx, f, (D::DIM + 2) as f64, out);
}

/// The Eq. (25) Hessian as a stencil: calls `emit(k, C_ij)` for the `k`-th neighbour `j` of
/// particle `i`, with `(∇∇f)_i = Σ_j C_ij (f_j − f_i)`, i.e.
/// `C_ij = −V_j F_ij ((d + 2) x_ij⊗x_ij / r_ij² − I)`. Zero-distance pairs are not emitted.
#[inline]
pub fn hessian_stencil_eq25<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    i: usize,
    mut emit: impl FnMut(usize, D::Matrix),
) {
    eq25_stencil(ctx, i, (D::DIM + 2) as f64, &mut emit);
}

/// The Eq. (25) stencil contracted with a matrix `M` (the DG pressure equation's `cof(A_i)`,
/// paper Eq. 22, written out in Eqs. 23–24): calls `emit(k, M : C_ij)` for the `k`-th
/// neighbour `j` of particle `i`, with [`hessian_stencil_eq25`]'s `C_ij`, computed without
/// forming it:
///
/// ```text
/// M : C_ij = −V_j F_ij ((d + 2) x_ijᵀ M x_ij / r_ij² − tr M)
/// ```
///
/// (`M : (x⊗x) = xᵀ M x`, `M : I = tr M`). With `x_ij·∇W_ij = s_ij r_ij²` (`s_ij` the
/// kernel's gradient factor, [`Pair::grad_factor`](crate::Pair)) and `r_ij² tr M = x_ijᵀ (tr M)
/// I x_ij`, the pair costs one division and one quadratic form of a matrix formed once per row:
///
/// ```text
/// M : C_ij = −V_j s_ij / (r_ij² + η²) · x_ijᵀ N x_ij,     N = (d + 2) M − (tr M) I
/// ```
///
/// `M : C_ij` is linear in `M`: a caller scaling every pair (the DG equation's `1/ρ_i`) passes
/// the scaled matrix.
///
/// Equal to contracting the matrices to round-off (tested, 2D and 3D). Zero-distance pairs
/// are not emitted.
#[inline]
pub fn hessian_stencil_eq25_contracted<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    i: usize,
    m: &D::Matrix,
    mut emit: impl FnMut(usize, f64),
) {
    // N of the doc above, once per row.
    let n = *m * (D::DIM + 2) as f64 - D::Matrix::IDENTITY * m.trace();
    let eta2 = laplacian_regulariser(ctx.kernel.h());
    ctx.for_each_pair(i, |p| {
        let r2 = p.x_ij.length_squared();
        if r2 == 0.0 {
            return;
        }
        let q = -ctx.volumes[p.j] * p.grad_factor / (r2 + eta2);
        emit(p.k, q * n.quadratic_form(p.x_ij));
    });
}

/// Calls `f(k, x_ij, r_ij², c_ij)` with `c_ij = −V_j F_ij` for every neighbour `j` (row
/// position `k`) of particle `i` at a non-zero distance: the scalar both Eq. (25) stencils
/// scale.
#[inline(always)]
fn eq25_pairs<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    i: usize,
    mut f: impl FnMut(usize, D::Vector, f64, f64),
) {
    let eta2 = laplacian_regulariser(ctx.kernel.h());
    ctx.for_each_pair(i, |p| {
        let r2 = p.x_ij.length_squared();
        if r2 == 0.0 {
            return;
        }
        let c = -ctx.volumes[p.j] * p.x_ij.dot(p.grad_w) / (r2 + eta2);
        f(p.k, p.x_ij, r2, c);
    });
}

#[inline(always)]
pub(crate) fn eq25_stencil<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    i: usize,
    coefficient: f64,
    emit: &mut impl FnMut(usize, D::Matrix),
) {
    eq25_pairs(ctx, i, |k, x_ij, r2, c| {
        emit(
            k,
            D::Matrix::outer(x_ij, x_ij * (c * coefficient / r2)) - D::Matrix::IDENTITY * c,
        );
    });
}

/// [`hessian`] with an explicit coefficient in place of `d + 2` (for the erratum test).
pub(crate) fn hessian_with_coefficient<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    f: &[f64],
    coefficient: f64,
    out: &mut [D::Matrix],
) {
    assert_eq!(f.len(), ctx.len());
    assert_eq!(out.len(), ctx.len());
    gather(out, |i| {
        let row = ctx.neighbors.row(i);
        let mut h = D::Matrix::ZERO;
        eq25_stencil(ctx, i, coefficient, &mut |k, c| {
            h += c * (f[row[k] as usize] - f[i])
        });
        h
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::Lattice;
    use sph_core::D3;
    use sph_kernels::KernelKind;

    /// Paper Eq. 25 prints the coefficient 4. In the continuum limit the operator with
    /// coefficient α gives `α/(2(d+2)) (δ tr H + 2H) − ½ δ tr H`: exactly `H` for α = d + 2, but
    /// `0.8 H − 1.2 δ` (tr H = 12) for α = 4 in 3D, i.e. diag(2, 4, 6) → (0.4, 2.0, 3.6).
    #[test]
    fn papers_2d_coefficient_fails_in_3d() {
        let lat = Lattice::<D3>::new(KernelKind::QuinticSpline, 1.3, 0.0);
        let f: Vec<f64> = lat
            .positions
            .iter()
            .map(|x| x.x * x.x + 2.0 * x.y * x.y + 3.0 * x.z * x.z)
            .collect();
        let mut h4 = vec![<D3 as Dim>::Matrix::ZERO; lat.len()];
        let mut h5 = h4.clone();
        lat.with_ctx(|ctx| {
            hessian_with_coefficient(ctx, &f, 4.0, &mut h4);
            hessian(ctx, &f, &mut h5);
        });
        let c = lat.centre();
        for (k, hk) in [2.0, 4.0, 6.0].into_iter().enumerate() {
            let with4 = h4[c].get(k, k);
            let with5 = h5[c].get(k, k);
            // Both to the quintic's h = 1.3 dx accuracy: 1.6 % of max |H| = 6 (see
            // `quadratic_field_accuracy_and_convergence_in_h`); 4 % of 6 allowed.
            let tol = 0.04 * 6.0;
            assert!(
                (with5 - hk).abs() < tol,
                "coefficient 5, H_{k}{k} = {with5}"
            );
            let predicted4 = 0.8 * hk - 1.2;
            assert!(
                (with4 - predicted4).abs() < tol,
                "coefficient 4, H_{k}{k} = {with4}"
            );
            assert!(
                (with4 - hk).abs() > 1.5,
                "coefficient 4 must be visibly wrong"
            );
        }
    }
}
