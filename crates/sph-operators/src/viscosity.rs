//! Laminar viscosity (Morris, Fox & Zhu 1997), the explicit viscous term of the momentum
//! equation (paper Eq. 1, `∇·(2μD)/ρ` for constant μ and ∇·u = 0).

use crate::context::{SphContext, laplacian_regulariser};
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;

/// Viscous acceleration, Morris et al. (1997), J. Comput. Phys. 136, 214–226, Eq. (8):
///
/// ```text
/// a_i = Σ_j m_j (μ_i + μ_j) / (ρ_i ρ_j) · F_ij · (u_i − u_j),   F_ij = x_ij·∇W_ij / (r_ij² + (0.01h)²)
/// ```
///
/// With constant kinematic viscosity `ν` (μ = ρν) and uniform density this is `ν` times the
/// Morris Laplacian of each velocity component, i.e. `ν ∇²u`. The result is **added** to `acc`.
/// Velocities of wall/ghost particles enter through `u` like any other neighbour's. Each pair
/// costs one division: with `x_ij·∇W_ij = s_ij r_ij²` (`s_ij` the kernel's gradient factor),
/// `m_j ν (ρ_i + ρ_j) s_ij r_ij² / (ρ_i ρ_j (r_ij² + η²))`.
///
/// Computed for the first `acc.len()` particles (all of them, or a prefix: see the crate
/// docs).
pub fn viscous_acceleration<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    masses: &[f64],
    densities: &[f64],
    nu: f64,
    u: &[D::Vector],
    acc: &mut [D::Vector],
) {
    assert!(masses.len() == ctx.len() && densities.len() == ctx.len() && u.len() == ctx.len());
    assert!(acc.len() <= ctx.len(), "at most one output per particle");
    // Gather: each particle reads its neighbours and writes only its own slot.
    let add = |i: usize| {
        let eta2 = laplacian_regulariser(ctx.kernel.h());
        let mut a = D::Vector::ZERO;
        ctx.for_each_pair(i, |p| {
            let j = p.j;
            if j == i {
                return;
            }
            let r2 = p.x_ij.length_squared();
            let c = masses[j] * nu * (densities[i] + densities[j]) * p.grad_factor * r2
                / (densities[i] * densities[j] * (r2 + eta2));
            a += (u[i] - u[j]) * c;
        });
        a
    };
    use rayon::prelude::*;
    acc.par_iter_mut()
        .enumerate()
        .with_min_len(crate::context::MIN_LEN)
        .for_each(|(i, a)| *a += add(i));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::Lattice;
    use sph_core::{MatrixOps, testing::SplitMix64};
    use sph_kernels::KernelKind;

    sph_core::dim_tests! {
        fn linear_velocity_has_no_viscous_force_and_quadratic_gives_nu_laplacian<D>() {
            let nu = 0.01;
            let mut rng = SplitMix64::new(4);
            for kind in [KernelKind::QuinticSpline, KernelKind::WendlandC2] {
                let lat = Lattice::<D>::new(kind, 1.3, 0.0);
                let n = lat.len();
                let masses = lat.volumes.clone();
                let rho = vec![1.0; n];
                // Linear field: zero viscous force in the interior.
                let g = D::Matrix::from_fn(|_, _| rng.uniform(-1.0, 1.0));
                let u: Vec<D::Vector> = lat.positions.iter().map(|x| g * *x).collect();
                let mut acc = vec![D::Vector::ZERO; n];
                lat.with_ctx(|ctx| viscous_acceleration(ctx, &masses, &rho, nu, &u, &mut acc));
                for &i in &lat.interior() {
                    assert!(acc[i].length() < 1e-10, "{kind:?}: linear field gives {:?}", acc[i]);
                }
                // u = (y², 0[, 0]): ν∇²u = (2ν, 0[, 0]), to the Morris Laplacian's lattice accuracy
                // (quintic 0.05 %, Wendland 2.6 % at h = 1.3 dx).
                let u: Vec<D::Vector> = lat.positions.iter().map(|x| D::Vector::from_fn(|k| if k == 0 { x.get(1) * x.get(1) } else { 0.0 })).collect();
                let mut acc = vec![D::Vector::ZERO; n];
                lat.with_ctx(|ctx| viscous_acceleration(ctx, &masses, &rho, nu, &u, &mut acc));
                let tol = if kind == KernelKind::QuinticSpline { 1e-3 } else { 4e-2 };
                for &i in &lat.interior() {
                    assert!((acc[i].get(0) / (2.0 * nu) - 1.0).abs() < tol, "{kind:?}: {:?}", acc[i]);
                    assert!(acc[i].get(1).abs() < 1e-10);
                }
                // The operator adds: a second call doubles the result.
                let first = acc.clone();
                lat.with_ctx(|ctx| viscous_acceleration(ctx, &masses, &rho, nu, &u, &mut acc));
                for (a, f) in acc.iter().zip(&first) {
                    assert!((*a - *f * 2.0).length() <= 1e-12 * f.length().max(1e-30));
                }
            }
        }

        fn pair_term_is_the_morris_form_with_f_from_its_definition<D>() {
            // The one-division pair term equals m_j ν (ρ_i + ρ_j)/(ρ_i ρ_j) F_ij (u_i − u_j)
            // with F_ij from its definition (`pair_f`: x_ij·∇W_ij/(r² + (0.01h)²)), at
            // non-uniform masses and densities, so neither the regulariser nor the density
            // factor can differ from the Morris form (the quadratic-field test above holds
            // only to the lattice error, with uniform ρ).
            let lat = Lattice::<D>::new(KernelKind::WendlandC2, 1.3, 0.1);
            let n = lat.len();
            let mut rng = SplitMix64::new(6);
            let u: Vec<D::Vector> = (0..n).map(|_| rng.vector::<D>(-1.0, 1.0)).collect();
            let masses: Vec<f64> = lat.volumes.iter().map(|v| v * rng.uniform(0.7, 1.3)).collect();
            let rho: Vec<f64> = (0..n).map(|_| rng.uniform(0.8, 1.25)).collect();
            let nu = 0.01;
            let mut acc = vec![D::Vector::ZERO; n];
            lat.with_ctx(|ctx| {
                viscous_acceleration(ctx, &masses, &rho, nu, &u, &mut acc);
                for i in 0..n {
                    let (mut want, mut scale) = (D::Vector::ZERO, 0.0);
                    for j in ctx.neighbors_of(i).filter(|&j| j != i) {
                        let f = crate::pair_f::<D, _>(ctx.kernel, ctx.pair(ctx.positions[i], j));
                        let t = (u[i] - u[j]) * (masses[j] * nu * (rho[i] + rho[j]) / (rho[i] * rho[j]) * f);
                        want += t;
                        scale += t.length();
                    }
                    assert!(scale > 0.0, "particle {i} has no neighbour");
                    assert!((acc[i] - want).length() <= 1e-12 * scale, "particle {i}: {:?} against {want:?}", acc[i]);
                }
            });
        }

        fn viscous_forces_conserve_momentum<D>() {
            // Pairwise antisymmetric: Σ m_i a_i = 0 for any velocity field (uniform masses).
            let lat = Lattice::<D>::new(KernelKind::QuinticSpline, 1.3, 0.1);
            let n = lat.len();
            let mut rng = SplitMix64::new(5);
            let u: Vec<D::Vector> = (0..n).map(|_| rng.vector::<D>(-1.0, 1.0)).collect();
            let mut acc = vec![D::Vector::ZERO; n];
            lat.with_ctx(|ctx| viscous_acceleration(ctx, &lat.volumes, &vec![1.0; n], 0.1, &u, &mut acc));
            let total: D::Vector = acc.iter().zip(&lat.volumes).map(|(a, m)| *a * *m).sum();
            let scale: f64 = acc.iter().map(|a| a.length()).sum::<f64>() * lat.volumes[0];
            assert!(total.length() < 1e-12 * scale, "net force {total:?} (scale {scale})");
        }
    }
}
