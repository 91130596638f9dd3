//! A particle-scale dissipation: hyperviscosity on the velocity's departure from its linear
//! part, which damps the particle-scale modes of a projection and leaves resolved flow (and
//! any linear field, at a free surface too) alone.

use crate::context::{SphContext, gather, laplacian_regulariser, pair_f};
use sph_core::{Dim, MatrixOps, VectorOps};
use sph_kernels::Kernel;

/// Smallest `det B_i` (relative to the interior's 1) for which [`hyperviscous_acceleration`]
/// renormalises a particle's gradient; below it (a particle with few neighbours, spray) the raw
/// gradient is used.
const MIN_DET: f64 = 1e-3;
/// Largest entry of `B_i⁻¹` accepted (as [`correction_matrices`](crate::correction_matrices)'s
/// `max_gain`).
const MAX_GAIN: f64 = 1e3;

/// Hyperviscous acceleration on the first `n = acc.len()` particles (the fluid; pairs with a
/// particle `j ≥ n`, a wall, are left out), **added** to `acc` at the particles `i` where
/// `active(i)` (the others' entries are left as they are; `l` is computed at every fluid
/// particle, so an active particle's acceleration does not depend on its neighbours' being
/// active):
///
/// ```text
/// a_i  = −ν₄ Σ_j w_ij (l_i − l_j),
/// l_i  = Σ_j w_ij d_ij,      d_ij = u_i − u_j − ½ (G_i + G_j) x_ij,
/// w_ij = 2 V_j F_ij,         F_ij = x_ij·∇W_ij / (r_ij² + (0.01h)²),
/// G_i  = Σ_j V_j (u_j − u_i) ⊗ B_i⁻ᵀ ∇W_ij,   B_i = Σ_j V_j ∇W_ij ⊗ (x_j − x_i)
/// ```
///
/// (sums over `j < n`). `Σ_j w_ij (f_i − f_j)` is Morris' Laplacian (paper Eq. 3's operator;
/// [`laplacian`](crate::laplacian)); its first application here is to the pair differences less
/// their linear part, `d_ij`, which vanishes for every linear field on any particle set where
/// `B_i` is invertible (renormalised `G_i`, Bonet & Lok 1999) — at a free surface or a cut
/// support too, where Morris' Laplacian of a linear field is `O(|∇u|/Δx)`. On a perfect lattice
/// `l` is a fourth-order operator (per Fourier mode, `Σ_j w_ij [(1 − cos θ) − ½ θ sin θ] =
/// Σ_j w_ij θ⁴/24 + …`, `θ = k·x_ij`, with an exact gradient), so a smooth mode of wavenumber `k`
/// is damped at a rate `∝ ν₄ k⁶ h²` and the particle-scale modes at `∝ ν₄/h⁴`: test
/// `hyperviscosity_damps_the_particle_scale_and_spares_smooth_modes`. Not in the paper: a
/// numerical dissipation in the spirit of the hyperviscosity of spectral and finite-difference
/// codes (the `−ν₄ ∇⁴u` of e.g. Lamorgese et al. 2005) for the particle-scale modes of an
/// approximate projection (docs/hard-cases.md, "Particle-scale dissipation").
///
/// `grad` and `lap` are the caller's scratch (length at least `n`), overwritten.
pub fn hyperviscous_acceleration<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    nu4: f64,
    u: &[D::Vector],
    active: impl Fn(usize) -> bool + Sync,
    grad: &mut [D::Matrix],
    lap: &mut [D::Vector],
    acc: &mut [D::Vector],
) {
    let n = acc.len();
    assert!(
        u.len() == ctx.len() && n <= ctx.len(),
        "one velocity per particle"
    );
    assert!(grad.len() >= n && lap.len() >= n, "scratch for the fluid");
    let (grad, lap) = (&mut grad[..n], &mut lap[..n]);
    let eta2 = laplacian_regulariser(ctx.kernel.h());
    let v = ctx.volumes;
    // The renormalised gradient over the fluid pairs.
    gather(grad, |i| {
        let (mut b, mut m) = (D::Matrix::ZERO, D::Matrix::ZERO);
        ctx.for_each_pair(i, |p| {
            if p.j >= n {
                return;
            }
            b += D::Matrix::outer(p.grad_w, -p.x_ij) * v[p.j];
            m += D::Matrix::outer(u[p.j] - u[i], p.grad_w * v[p.j]);
        });
        match b
            .try_inverse(MIN_DET)
            .filter(|inv| crate::correction::gain::<D>(inv) <= MAX_GAIN)
        {
            Some(l) => m * l.transpose(),
            None => m,
        }
    });
    let grad = &*grad;
    let w = |p: &crate::context::Pair<D::Vector>| {
        let r2 = p.x_ij.length_squared();
        2.0 * v[p.j] * p.grad_factor * r2 / (r2 + eta2)
    };
    gather(lap, |i| {
        let mut l = D::Vector::ZERO;
        ctx.for_each_pair(i, |p| {
            if p.j >= n || p.j == i {
                return;
            }
            let d = u[i] - u[p.j] - (grad[i] + grad[p.j]) * p.x_ij * 0.5;
            l += d * w(&p);
        });
        l
    });
    let lap = &*lap;
    use rayon::prelude::*;
    acc.par_iter_mut()
        .enumerate()
        .with_min_len(crate::context::MIN_LEN)
        .for_each(|(i, a)| {
            if !active(i) {
                return;
            }
            let mut s = D::Vector::ZERO;
            ctx.for_each_pair(i, |p| {
                if p.j >= n || p.j == i {
                    return;
                }
                s += (lap[i] - lap[p.j]) * w(&p);
            });
            *a -= s * nu4;
        });
}

/// An upper bound on the magnitude of Morris' Laplacian's eigenvalues on a perfect lattice of
/// particle volume `volume` (Gershgorin: `2 Σ_k V |w(x_k)|`, `w` as in
/// [`hyperviscous_acceleration`], over the lattice's points within the support). The automatic
/// time step keeps `Δt ≤ K/(ν₄ λ_G²)` (`K` = `sph_integrators::HYPERVISCOUS_STEP`): on the perfect lattice the operator's largest damping
/// rate, the particle-scale mode's, is 0.38 ν₄ λ_G² in 2D and 0.27 ν₄ λ_G² in 3D (Wendland C2
/// at `h = 1.3 Δx`; test `hyperviscosity_damps_the_particle_scale_and_spares_smooth_modes`); on
/// blocks with free edges, perfect or jittered by up to 30 % of Δx, the operator's spectral
/// radius stays within 0.47–0.85 ν₄ λ_G² in 2D and 0.35–0.50 in 3D (test
/// `the_lattice_bound_bounds_the_spectrum_on_disordered_blocks`); not proven for every set.
pub fn lattice_laplacian_bound<D: Dim, K: Kernel<D>>(kernel: &K, volume: f64) -> f64 {
    2.0 * crate::density::over_lattice::<D, K>(kernel, volume, |x| {
        (2.0 * volume * pair_f::<D, K>(kernel, x)).abs()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::Lattice;
    use sph_core::testing::SplitMix64;
    use sph_kernels::KernelKind;

    fn accelerate<D: Dim>(lat: &Lattice<D>, u: &[D::Vector]) -> Vec<D::Vector> {
        let n = lat.len();
        let mut grad = vec![D::Matrix::ZERO; n];
        let mut lap = vec![D::Vector::ZERO; n];
        let mut acc = vec![D::Vector::ZERO; n];
        lat.with_ctx(|ctx| {
            hyperviscous_acceleration(ctx, 1.0, u, |_| true, &mut grad, &mut lap, &mut acc)
        });
        acc
    }

    sph_core::dim_tests! {
        fn a_linear_field_feels_no_hyperviscosity_even_where_the_support_is_cut<D>() {
            // A jittered block: its edge particles' supports are cut as at a free surface.
            let mut rng = SplitMix64::new(7);
            for kind in [KernelKind::WendlandC2, KernelKind::QuinticSpline] {
                let lat = Lattice::<D>::new(kind, 1.3, 0.2);
                let g = D::Matrix::from_fn(|_, _| rng.uniform(-1.0, 1.0));
                let c = rng.vector::<D>(-1.0, 1.0);
                let u: Vec<D::Vector> = lat.positions.iter().map(|x| g * *x + c).collect();
                let acc = accelerate(&lat, &u);
                let h = lat.kernel.h();
                // Scale: |∇u| / h³ per unit ν₄ (what the plain Laplacian-squared would give at an edge).
                let scale = 1.0 / h.powi(3);
                let worst = acc.iter().map(|a| a.length()).fold(0.0, f64::max);
                assert!(worst < 1e-9 * scale, "{kind:?}: {worst:e} against {scale:e}");
                // The plain Morris Laplacian of the same field at the block's edge is far from 0.
                let mut l = vec![D::Vector::ZERO; lat.len()];
                let masses = lat.volumes.clone();
                let rho = vec![1.0; lat.len()];
                lat.with_ctx(|ctx| crate::viscous_acceleration(ctx, &masses, &rho, 1.0, &u, &mut l));
                let edge = l.iter().map(|a| a.length()).fold(0.0, f64::max);
                println!("{} {kind:?}: largest |a| {worst:.3e}, the plain Laplacian's at the edge {edge:.3e}", D::NAME);
                assert!(edge > 0.1 / h, "{kind:?}: the edge's Laplacian {edge:e}");
            }
        }

        fn hyperviscosity_damps_the_particle_scale_and_spares_smooth_modes<D>() {
            // u = (0, cos k x[, 0]) on the perfect lattice: at the centre (two supports of full
            // support around it) a = −r(k) u with r(k) ≥ 0; r falls steeply with k h.
            let lat = Lattice::<D>::with_margin(KernelKind::WendlandC2, 1.3, 0.0, 2 * 4 + 3);
            let (i, h, dx) = (lat.centre(), lat.kernel.h(), lat.dx);
            let xi = lat.positions[i];
            let rate = |k: f64| {
                let u: Vec<D::Vector> = lat.positions.iter()
                    .map(|x| D::Vector::from_fn(|a| if a == 1 { (k * (x.get(0) - xi.get(0))).cos() } else { 0.0 }))
                    .collect();
                let acc = accelerate(&lat, &u);
                -acc[i].get(1) / u[i].get(1)
            };
            let grid = rate(std::f64::consts::PI / dx);
            let bound = lattice_laplacian_bound::<D, _>(&lat.kernel, lat.volumes[0]);
            println!("{}: grid-mode rate {grid:.4e} (bound² {:.4e})", D::NAME, bound * bound);
            assert!(grid > 0.0 && grid <= bound * bound, "{grid:e} {bound:e}");
            let mut last = grid;
            for kh in [1.5, 1.0, 0.6, 0.3, 0.15] {
                let r = rate(kh / h);
                println!("{}: k h = {kh}: rate / grid rate {:.3e}", D::NAME, r / grid);
                assert!(r >= 0.0 && r < last, "k h = {kh}: {r:e} after {last:e}");
                last = r;
            }
            // k h = 0.15 (about 32 particles per wavelength): damped a million times less than the
            // particle scale.
            assert!(last < 1e-6 * grid, "{:e}", last / grid);
        }

        fn the_lattice_bound_bounds_the_spectrum_on_disordered_blocks<D>() {
            // The operator's spectral radius (power iteration on `u ↦ a(u)`, ν₄ = 1) on blocks with
            // free edges, perfect and jittered by up to 10, 20, 30 % of Δx per axis, against
            // `λ_G²` of the perfect lattice: the automatic step's `Δt ≤ K/(ν₄ λ_G²)` then keeps
            // `Δt |λ|` at most `K` times the ratio. Measured (Wendland C2, h = 1.3 Δx): 2D 0.47,
            // 0.53, 0.65, 0.85; 3D 0.35, 0.38, 0.43, 0.50.
            let margin = if D::DIM == 2 { 12 } else { 4 };
            let mut last = 0.0;
            for (jitter, most) in [(0.0, 0.5), (0.1, 0.6), (0.2, 0.7), (0.3, 0.9)] {
                let lat = Lattice::<D>::with_margin(KernelKind::WendlandC2, 1.3, jitter, margin);
                let n = lat.len();
                let bound = lattice_laplacian_bound::<D, _>(&lat.kernel, lat.volumes[0]);
                let mut rng = SplitMix64::new(3);
                let mut v: Vec<D::Vector> = (0..n).map(|_| rng.vector::<D>(-1.0, 1.0)).collect();
                let norm = |v: &[D::Vector]| v.iter().map(|x| x.dot(*x)).sum::<f64>().sqrt();
                let mut radius = 0.0;
                for _ in 0..400 {
                    let a = accelerate(&lat, &v);
                    let na = norm(&a);
                    radius = na / norm(&v);
                    v = a.iter().map(|x| *x * (1.0 / na)).collect();
                }
                // The dominant mode is damped: its Rayleigh quotient is −radius.
                let a = accelerate(&lat, &v);
                let rayleigh: f64 = a.iter().zip(&v).map(|(x, y)| x.dot(*y)).sum::<f64>() / norm(&v).powi(2);
                let ratio = radius / (bound * bound);
                println!("{} jitter {jitter}: spectral radius / λ_G² = {ratio:.4}", D::NAME);
                assert!((rayleigh + radius).abs() <= 1e-3 * radius, "{rayleigh:e} {radius:e}");
                assert!(ratio <= most && ratio >= last, "jitter {jitter}: {ratio}");
                last = ratio;
            }
        }

        fn inactive_particles_keep_their_entry_and_active_ones_feel_the_full_term<D>() {
            // Noise on a jittered block; every other particle inactive, its entry preset.
            let mut rng = SplitMix64::new(11);
            let lat = Lattice::<D>::new(KernelKind::WendlandC2, 1.3, 0.2);
            let n = lat.len();
            let u: Vec<D::Vector> = (0..n).map(|_| rng.vector::<D>(-1.0, 1.0)).collect();
            let full = accelerate(&lat, &u);
            let preset = D::Vector::from_fn(|k| k as f64 + 0.5);
            let mut acc = vec![preset; n];
            let (mut grad, mut lap) = (vec![D::Matrix::ZERO; n], vec![D::Vector::ZERO; n]);
            lat.with_ctx(|ctx| {
                hyperviscous_acceleration(ctx, 1.0, &u, |i| i % 2 == 0, &mut grad, &mut lap, &mut acc)
            });
            let mut felt = 0;
            for i in 0..n {
                if i % 2 == 0 {
                    // Bit for bit the unmasked term, added to the preset entry.
                    assert_eq!(acc[i], preset + full[i], "particle {i}");
                    felt += usize::from(full[i].length() > 0.0);
                } else {
                    assert_eq!(acc[i], preset, "particle {i}");
                }
            }
            assert!(felt > n / 4, "only {felt} of {n} active particles felt the term");
        }
    }
}
