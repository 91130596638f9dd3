use crate::context::{SphContext, gather};
use crate::correction::corrected;
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;

/// Which discrete gradient to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum GradientForm {
    /// `∇f_i = Σ_j V_j (f_j − f_i) ∇W_ij`: zero for a constant field, exact for linear fields
    /// when renormalised. The default, and the one that conserves volume best in the drops.
    #[default]
    Difference,
    /// `∇f_i = Σ_j V_j (f_i + f_j) ∇W_ij`, the uniform-density form of the momentum-conserving
    /// pressure gradient `ρ_i Σ_j m_j (p_i/ρ_i² + p_j/ρ_j²) ∇W_ij` (Monaghan 1992). Exact for
    /// linear fields only where `Σ_j V_j ∇W_ij = 0` (the interior of a regular lattice).
    Symmetric,
    /// `∇f_i = Σ_j V_j (f_i L_i + f_j L_j) ∇W_ij`: the negative adjoint, in the
    /// volume-weighted inner product, of the renormalised divergence
    /// `∇·u_i = Σ_j V_j (u_j − u_i)·L_i ∇W_ij`, so a projection built on the pair creates no
    /// kinetic energy while its divergence stays exact for linear fields (Bonet & Lok 1999's
    /// variational correction). Without renormalisation (`L = I`) it is [`Self::Symmetric`].
    Adjoint,
}

/// Gradient of the scalar field `f` (see [`GradientForm`]); `corrections` are the optional
/// renormalisation matrices `L_i` of [`correction_matrices`](crate::correction_matrices).
///
/// Computed for the first `out.len()` particles (all of them, or a prefix: see the crate
/// docs).
pub fn gradient<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    f: &[f64],
    form: GradientForm,
    corrections: Option<&[D::Matrix]>,
    out: &mut [D::Vector],
) {
    assert_eq!(f.len(), ctx.len());
    assert!(out.len() <= ctx.len(), "at most one output per particle");
    let sign = match form {
        GradientForm::Difference => -1.0,
        GradientForm::Symmetric | GradientForm::Adjoint => 1.0,
    };
    if let (GradientForm::Adjoint, Some(l)) = (form, corrections) {
        assert_eq!(l.len(), ctx.len(), "one correction per particle");
        gather(out, |i| {
            let mut own = D::Vector::ZERO;
            let mut others = D::Vector::ZERO;
            ctx.for_each_pair(i, |p| {
                let vj = ctx.volumes[p.j];
                own += p.grad_w * vj;
                others += (l[p.j] * p.grad_w) * (vj * f[p.j]);
            });
            (l[i] * own) * f[i] + others
        });
        return;
    }
    gather(out, |i| {
        let fi = sign * f[i];
        let mut acc = D::Vector::ZERO;
        ctx.for_each_pair(i, |p| {
            acc += p.grad_w * (ctx.volumes[p.j] * (f[p.j] + fi));
        });
        corrected::<D>(corrections, i, acc)
    });
}
