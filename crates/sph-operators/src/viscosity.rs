//! Laminar viscosity (Morris, Fox & Zhu 1997), the explicit viscous term of the momentum
//! equation (paper Eq. 1, `∇·(2μD)/ρ` for constant μ and ∇·u = 0).

use crate::context::{SphContext, gather, laplacian_regulariser};
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
    use rayon::prelude::*;
    acc.par_iter_mut()
        .enumerate()
        .with_min_len(crate::context::MIN_LEN)
        .for_each(|(i, a)| *a += morris_sum(ctx, masses, densities, nu, u, i));
}

/// The Morris pair sum `Σ_j m_j ν (ρ_i + ρ_j)/(ρ_i ρ_j) F_ij (u_i − u_j)` at particle `i`.
#[inline]
fn morris_sum<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    masses: &[f64],
    densities: &[f64],
    nu: f64,
    u: &[D::Vector],
    i: usize,
) -> D::Vector {
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
}

/// The coefficient `c` of the leading error of Morris' Laplacian on smooth fields:
///
/// ```text
/// L f = ∇²f + c ∇⁴f + O(h⁴),   c = M₂ / (4D),   M₂ = ∫ r² W dV  (Kernel::second_moment)
/// ```
///
/// Derivation (continuous form of Eq. 8 above on a Fourier mode `f = e^{ik·x}`):
/// `L f = 2 ∫ (f(x) − f(x + r)) W'(r)/r dV = −2 ∫ (1 − cos k·r) W'(r)/r dV`. Expanding
/// `1 − cos θ = θ²/2 − θ⁴/24`, with the angular means `⟨(k̂·r̂)²⟩ = 1/D`,
/// `⟨(k̂·r̂)⁴⟩ = 3/(D(D + 2))` and the integrations by parts `∫ r W' dV = −D`,
/// `∫ r³ W' dV = −(D + 2) M₂`, gives `L̂(k) = −k² + k⁴ M₂/(4D)`. So Morris' operator
/// under-estimates the decay of a smooth mode by the fraction `k² M₂/(4D)`: for the quintic
/// spline at `h = 1.3 dx` (2D, `M₂ = 2771/2868 h²`) and the Taylor–Green mode (`k² = 8π²`) that is
/// 2.6 / 0.64 / 0.16 % at 25 / 50 / 100 particles across (a lattice measures 2.5 / 0.58 / 0.10 %,
/// test `morris_error_coefficient_predicts_the_lattice_symbol`).
pub fn morris_error_coefficient<D: Dim, K: Kernel<D>>(kernel: &K) -> f64 {
    kernel.second_moment() / (4.0 * D::DIM as f64)
}

/// The fourth-order correction of the viscous acceleration `a = ν L u`
/// ([`viscous_acceleration`]), subtracting the leading error of Morris' Laplacian:
///
/// ```text
/// a_i ← a_i − c (L a)_i,   c = morris_error_coefficient,   (L a)_i = Σ_j m_j (ρ_i + ρ_j)/(ρ_i ρ_j) F_ij (a_i − a_j)
/// ```
///
/// so `ν(L − c L²) u = ν∇²u + O(h⁴)` on smooth fields (`L² u = ∇⁴u + O(h²)`), exact for
/// polynomials of degree ≤ 4 where `L` is exact for degree ≤ 2 (an undisturbed lattice). Its
/// symbol `−k² + c k⁴ − c(−k² + c k⁴)²` raises the largest eigenvalue of the explicit viscous
/// step by about 1.5× (quintic, 2D lattice): the automatic time step's viscous limit keeps a
/// margin of 2.8× for it. `a` holds every particle's value (length `ctx.len()`); only
/// particles for which `corrected(i)` holds are changed (the caller leaves out those whose
/// neighbourhood holds a wall or a free surface, where `L` itself is first-order and `a_j` of a
/// wall particle is not defined). Writes `out[i]` for the first `out.len()` particles.
pub fn viscous_correction<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    masses: &[f64],
    densities: &[f64],
    c: f64,
    a: &[D::Vector],
    corrected: impl Fn(usize) -> bool + Sync,
    out: &mut [D::Vector],
) {
    assert!(masses.len() == ctx.len() && densities.len() == ctx.len() && a.len() == ctx.len());
    assert!(out.len() <= ctx.len(), "at most one output per particle");
    gather(out, |i| {
        if corrected(i) {
            a[i] - morris_sum(ctx, masses, densities, 1.0, a, i) * c
        } else {
            a[i]
        }
    });
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

        fn morris_error_coefficient_predicts_the_lattice_symbol<D>() {
            // A smooth mode u = (cos k·x, 0[, 0]) on the undisturbed lattice, quintic spline at
            // h = 1.3 dx: Morris' Laplacian under-estimates −k² by the fraction c k²
            // (`morris_error_coefficient`), and the corrected operator removes that error.
            let lat = Lattice::<D>::with_margin(KernelKind::QuinticSpline, 1.3, 0.0, 2 * 4 + 3);
            let n = lat.len();
            let h = lat.kernel.h();
            let c = morris_error_coefficient::<D, _>(&lat.kernel);
            assert!((c / (h * h) - if D::DIM == 2 { 2771.0 / 2868.0 / 8.0 } else { 1.4 / 12.0 }).abs() < 1e-12);
            let masses = lat.volumes.clone();
            let rho = vec![1.0; n];
            let i = lat.centre();
            let xi = lat.positions[i];
            for kh in [0.2, 0.3, 0.45] {
                // Along a lattice diagonal in the x–y plane and along x.
                for dir in [D::Vector::from_fn(|k| if k == 0 { 1.0 } else { 0.0 }),
                            D::Vector::from_fn(|k| if k < 2 { std::f64::consts::FRAC_1_SQRT_2 } else { 0.0 })] {
                    // The lattice's own error of L on a quadratic along `dir` (k-independent, the
                    // 0.05 % of the test above): L(s²) = 2 (1 + e_lat), s = dir·(x − x_i).
                    let q: Vec<D::Vector> = lat.positions.iter()
                        .map(|x| D::Vector::from_fn(|a| if a == 0 { dir.dot(*x - xi).powi(2) } else { 0.0 }))
                        .collect();
                    let mut lq = vec![D::Vector::ZERO; n];
                    lat.with_ctx(|ctx| viscous_acceleration(ctx, &masses, &rho, 1.0, &q, &mut lq));
                    let e_lat = lq[i].get(0) / 2.0 - 1.0;
                    let k = dir * (kh / h);
                    let k2 = k.length_squared();
                    let u: Vec<D::Vector> = lat.positions.iter()
                        .map(|x| D::Vector::from_fn(|a| if a == 0 { (k.dot(*x - xi)).cos() } else { 0.0 }))
                        .collect();
                    let mut a = vec![D::Vector::ZERO; n];
                    lat.with_ctx(|ctx| viscous_acceleration(ctx, &masses, &rho, 1.0, &u, &mut a));
                    let morris = a[i].get(0) / -k2 - 1.0;
                    let predicted = -c * k2;
                    let mut b = vec![D::Vector::ZERO; n];
                    lat.with_ctx(|ctx| viscous_correction(ctx, &masses, &rho, c, &a, |_| true, &mut b));
                    let corrected = b[i].get(0) / -k2 - 1.0;
                    println!("{} kh = {kh}: Morris {morris:+.3e} (predicted {predicted:+.3e}, lattice {e_lat:+.1e}), corrected {corrected:+.3e}", D::NAME);
                    // Beside the lattice error, the continuous prediction holds to its O((kh)⁴)
                    // remainder, and the correction removes at least 90 % of it.
                    assert!((morris - e_lat - predicted).abs() < 0.1 * predicted.abs(), "kh = {kh}: {morris} against {predicted} + {e_lat}");
                    assert!((corrected - e_lat).abs() < 0.1 * predicted.abs(), "kh = {kh}: {corrected} against Morris {morris}");
                    // Particles left out keep the uncorrected value, bit for bit.
                    lat.with_ctx(|ctx| viscous_correction(ctx, &masses, &rho, c, &a, |j| j != i, &mut b));
                    assert_eq!(b[i], a[i]);
                }
            }
        }

        fn corrected_explicit_step_is_stable_at_the_automatic_viscous_limit<D>() {
            // The explicit step u ← u + Δt ν (L − cL²) u at ν Δt / h² = 0.125 (the automatic
            // time step's viscous limit, `sph_integrators::AutoTimeStep`): by power iteration its
            // largest |eigenvalue| stays ≤ 1 for every kernel, on the lattice and with a 10 %
            // jitter. (Lattice symbol: `L − cL²` raises Morris' largest eigenvalue 1.44–1.47-fold;
            // the step is stable up to ν Δt / h² = 0.21 (Wendland C2, 3D) – 0.35 (quintic, 2D).)
            for kind in [KernelKind::QuinticSpline, KernelKind::WendlandC2, KernelKind::CubicSpline] {
                for jitter in [0.0, 0.1] {
                    let lat = Lattice::<D>::new(kind, 1.3, jitter);
                    let n = lat.len();
                    let h = lat.kernel.h();
                    let c = morris_error_coefficient::<D, _>(&lat.kernel);
                    let masses = lat.volumes.clone();
                    let rho = vec![1.0; n];
                    let s = 0.125 * h * h;
                    let mut rng = SplitMix64::new(9);
                    let mut v: Vec<D::Vector> = (0..n).map(|_| rng.vector::<D>(-1.0, 1.0)).collect();
                    let norm = |v: &[D::Vector]| v.iter().map(|x| x.length_squared()).sum::<f64>().sqrt();
                    let (mut a, mut b) = (vec![D::Vector::ZERO; n], vec![D::Vector::ZERO; n]);
                    let mut growth = 0.0;
                    for _ in 0..300 {
                        a.fill(D::Vector::ZERO);
                        lat.with_ctx(|ctx| viscous_acceleration(ctx, &masses, &rho, 1.0, &v, &mut a));
                        lat.with_ctx(|ctx| viscous_correction(ctx, &masses, &rho, c, &a, |_| true, &mut b));
                        let before = norm(&v);
                        for (x, d) in v.iter_mut().zip(&b) {
                            *x += *d * s;
                        }
                        growth = norm(&v) / before;
                    }
                    println!("{} {kind:?} jitter {jitter}: growth per step {growth:.6}", D::NAME);
                    assert!(growth <= 1.0, "{kind:?}, jitter {jitter}: the explicit step grows {growth} per step");
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
