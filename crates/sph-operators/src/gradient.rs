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

/// The kernel gradient's lattice factor `β = −(1/D) Σ_k V (k Δx)·∇W(k Δx)` over an infinite
/// perfect lattice of spacing `Δx = V^{1/D}` (`k` over `ℤ^D`): on such a lattice
/// `Σ_j V_j x_ij ⊗ ∇W_ij = −β I`, so the difference and symmetric gradients of a linear field,
/// the divergence of a linear velocity and Morris' Laplacian of a quadratic (paper Eqs. 11, 13,
/// 3) all come out `β` times the exact value. `β → 1` as `h/Δx` grows; at `h = 1.3 Δx` it is
/// 0.9739 / 0.9789 for Wendland C2 (2D / 3D) and within 6e-4 of 1 for the quintic spline.
///
/// A projection whose Laplacian and divergence carry `β` (so the pressure equation is right)
/// but whose velocity correction is `β` times the pressure's gradient removes only the fraction
/// `β` of the divergence each step; the rest comes back in the next source and the pressure
/// settles `1/β` too high. Dividing the pressure gradient by `β` makes the pair consistent on the
/// lattice (`SimConfig::lattice_normalised` in `sph-integrators`).
pub fn lattice_gradient_factor<D: Dim, K: Kernel<D>>(kernel: &K, volume: f64) -> f64 {
    let sum = crate::density::over_lattice::<D, K>(kernel, volume, |x| {
        let r = x.length();
        if r > 0.0 { r * kernel.dw_dr(r) } else { 0.0 }
    });
    -sum * volume / D::DIM as f64
}
