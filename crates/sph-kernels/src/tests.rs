//! Kernel tests, each for every kernel in both dimensions.

use crate::{AnyKernel, Kernel, KernelKind, QuinticSpline};
use sph_core::testing::lattice;
use sph_core::{Dim, MatrixOps, VectorOps};
use std::f64::consts::PI;

/// `(P_n(x), P_n'(x))` by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let pk = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = pk;
    }
    (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton iteration on P_n).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            loop {
                let (p, dp) = legendre(n, x);
                let dx = p / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    let (_, dp) = legendre(n, x);
                    return (x, 2.0 / ((1.0 - x * x) * dp * dp));
                }
            }
        })
        .collect()
}

/// `∫ W dV` by radial Gauss–Legendre quadrature, 12 points on each unit-`q` interval between the
/// spline knots (exact for the polynomial pieces, degree ≤ 23).
fn integrate<D: Dim>(k: &impl Kernel<D>) -> f64 {
    integrate_moment::<D>(k, 0)
}

/// `∫ r^power W dV` by the same quadrature.
fn integrate_moment<D: Dim>(k: &impl Kernel<D>, power: i32) -> f64 {
    let gl = gauss_legendre(12);
    let h = k.h();
    let pieces = (k.support_radius() / h).round() as usize;
    let shell = |r: f64| {
        if D::DIM == 2 {
            2.0 * PI * r
        } else {
            4.0 * PI * r * r
        }
    };
    let mut sum = 0.0;
    for p in 0..pieces {
        let (a, b) = (p as f64 * h, (p + 1) as f64 * h);
        for &(x, wgt) in &gl {
            let r = 0.5 * (a + b) + 0.5 * (b - a) * x;
            sum += 0.5 * (b - a) * wgt * shell(r) * r.powi(power) * k.w(r);
        }
    }
    sum
}

fn kernels<D: Dim>(h: f64) -> Vec<AnyKernel<D>> {
    KernelKind::ALL.iter().map(|k| k.build::<D>(h)).collect()
}

/// Lattice sums at the centre particle of a lattice wide enough to cover the support:
/// (Σ V_j W_ij, max |Σ V_j ∇W_ij|, max |Σ V_j x_ij ⊗ ∇W_ij + I|).
fn lattice_sums<D: Dim>(k: &AnyKernel<D>, dx: f64) -> (f64, f64, f64) {
    let per_side = 2 * (k.support_radius() / dx).ceil() as usize + 3;
    let pts = lattice::<D>(per_side, dx);
    let vol = dx.powi(D::DIM as i32);
    let centre = pts[pts.len() / 2];
    assert!(
        centre.length() < 1e-12,
        "odd lattice is centred on a particle"
    );
    let mut sw = 0.0;
    let mut sg = D::Vector::ZERO;
    let mut m = D::Matrix::ZERO;
    for &xj in &pts {
        let x_ij = centre - xj;
        sw += vol * k.w(x_ij.length());
        let g = k.grad_w(x_ij);
        sg += g * vol;
        m += D::Matrix::outer(x_ij, g) * vol;
    }
    let dev = m + D::Matrix::IDENTITY;
    let mut max_dev: f64 = 0.0;
    for i in 0..D::DIM {
        for j in 0..D::DIM {
            max_dev = max_dev.max(dev.get(i, j).abs());
        }
    }
    let max_g = (0..D::DIM).map(|i| sg.get(i).abs()).fold(0.0, f64::max);
    (sw, max_g, max_dev)
}

sph_core::dim_tests! {
    fn normalisation_integrates_to_one<D>() {
        for h in [0.013, 1.0, 7.5] {
            for k in kernels::<D>(h) {
                let integral = integrate::<D>(&k);
                assert!((integral - 1.0).abs() < 1e-8, "{k:?}: ∫W dV = {integral}");
            }
        }
    }

    fn second_moments_match_quadrature<D>() {
        // The shapes' exact M₂ (rationals worked out from the polynomials) against ∫ r² W dV by
        // quadrature: a wrong constant sets a wrong viscous correction.
        for h in [0.013, 1.0, 7.5] {
            for k in kernels::<D>(h) {
                let quadrature = integrate_moment::<D>(&k, 2);
                let exact = k.second_moment();
                assert!(
                    (quadrature / exact - 1.0).abs() < 1e-10,
                    "{k:?}: ∫ r² W dV = {quadrature}, second_moment() = {exact}"
                );
            }
        }
    }

    fn lattice_sums_at_h_1_3_dx<D>() {
        // Measured at h = 1.3 dx (`cargo test -p sph-kernels lattice_sums -- --nocapture`):
        //              |ΣVW − 1|       |ΣV x⊗∇W + I|
        //   quintic    4.5e-5 / 1.2e-4  6.1e-4 / 1.7e-4   (2D / 3D)
        //   Wendland   1.0e-2 / 9.5e-3  2.6e-2 / 2.1e-2
        //   cubic      5.3e-5 / 2.7e-3  1.1e-2 / 6.5e-3
        // Wendland C2 and the cubic spline are an order of magnitude worse than the quintic
        // because their support (2h = 2.6 dx) holds fewer lattice shells. Bounds: measured × ≤ 1.6.
        let dx = 0.1;
        for k in kernels::<D>(1.3 * dx) {
            let (sw, sg, dev) = lattice_sums::<D>(&k, dx);
            println!("{} {k:?}: |ΣVW−1| = {:.3e}, |ΣV∇W| = {sg:.1e}, |ΣV x⊗∇W + I| = {dev:.3e}",
                D::NAME, (sw - 1.0).abs());
            let (bound_w, bound_m) = match (k, D::DIM) {
                (AnyKernel::QuinticSpline(_), 2) => (QUINTIC_2D.0, QUINTIC_2D.1),
                (AnyKernel::QuinticSpline(_), _) => (QUINTIC_3D.0, QUINTIC_3D.1),
                (AnyKernel::WendlandC2(_), 2) => (WENDLAND_2D.0, WENDLAND_2D.1),
                (AnyKernel::WendlandC2(_), _) => (WENDLAND_3D.0, WENDLAND_3D.1),
                (AnyKernel::CubicSpline(_), 2) => (CUBIC_2D.0, CUBIC_2D.1),
                (AnyKernel::CubicSpline(_), _) => (CUBIC_3D.0, CUBIC_3D.1),
            };
            assert!((sw - 1.0).abs() < bound_w, "{k:?}: Σ V W = {sw}");
            assert!(sg < 1e-12 / dx, "{k:?}: Σ V ∇W = {sg} (must vanish by symmetry)");
            assert!(dev < bound_m, "{k:?}: Σ V x⊗∇W + I deviates by {dev}");
        }
    }

    fn compact_support_and_positivity<D>() {
        for k in kernels::<D>(0.7) {
            let rs = k.support_radius();
            for t in [1.0, 1.0 + 1e-12, 1.5, 10.0] {
                assert_eq!(k.w(rs * t), 0.0, "{k:?}");
                assert_eq!(k.dw_dr(rs * t), 0.0, "{k:?}");
            }
            for i in 0..1000 {
                let r = rs * i as f64 / 1000.0;
                assert!(k.w(r) > 0.0, "{k:?}: W({r}) must be positive inside the support");
                assert!(k.dw_dr(r) <= 0.0, "{k:?}: W must be non-increasing");
            }
            assert_eq!(k.dw_dr(0.0), 0.0);
            assert_eq!(k.grad_w(D::Vector::ZERO), D::Vector::ZERO);
        }
    }

    fn continuity_at_knots_and_derivative_consistency<D>() {
        let h = 1.0;
        for k in kernels::<D>(h) {
            let pieces = (k.support_radius() / h).round() as usize;
            let scale = k.w(0.0);
            for knot in 1..=pieces {
                let r = knot as f64 * h;
                let eps = 1e-9;
                // W is C2 and dW/dr C1 across every knot: jumps are O(eps), not O(1).
                assert!((k.w(r - eps) - k.w(r + eps)).abs() < 1e-7 * scale, "{k:?} W at q={knot}");
                assert!((k.dw_dr(r - eps) - k.dw_dr(r + eps)).abs() < 1e-7 * scale, "{k:?} W' at q={knot}");
            }
            // dW/dr equals the central difference of W everywhere inside the support.
            for i in 1..300 {
                let r = k.support_radius() * i as f64 / 300.0;
                let e = 1e-6;
                let fd = (k.w(r + e) - k.w(r - e)) / (2.0 * e);
                assert!((fd - k.dw_dr(r)).abs() < 1e-6 * scale, "{k:?}: r = {r}");
            }
            // ∇W points along x_ij with magnitude |dW/dr|.
            let x = D::Vector::from_fn(|i| 0.3 + 0.2 * i as f64);
            let g = k.grad_w(x);
            assert!((g - x * (k.dw_dr(x.length()) / x.length())).length() < 1e-15);
        }
    }

    fn gradient_factor_equals_the_derivative_over_r<D>() {
        // `grad_factor_at(r)` is `(dW/dr)/r`: Wendland C2 by its closed form `σ/h^(D+2) ·
        // (−5)(1 − q/2)³` (no division), the splines by the division itself (bitwise).
        for h in [0.013, 1.0, 7.5] {
            for k in kernels::<D>(h) {
                let rs = k.support_radius();
                let mut worst: f64 = 0.0;
                for i in 1..2000 {
                    let r = rs * i as f64 / 2000.0;
                    let (got, want) = (k.grad_factor_at(r), k.dw_dr(r) / r);
                    assert!(got < 0.0, "{k:?}: r = {r}");
                    if matches!(k, AnyKernel::WendlandC2(_)) {
                        worst = worst.max(((got - want) / want).abs());
                    } else {
                        assert_eq!(got.to_bits(), want.to_bits(), "{k:?}: r = {r}");
                    }
                }
                assert!(worst < 1e-14, "{k:?}: relative difference {worst:e}");
                for r in [0.0, rs, rs * (1.0 + 1e-12), 2.0 * rs] {
                    assert_eq!(k.grad_factor_at(r), 0.0, "{k:?}: r = {r}");
                }
            }
        }
    }
}

// (|Σ V W − 1|, |Σ V x⊗∇W + I|_max) bounds at h = 1.3 dx: the values measured above × ≤ 1.6.
const QUINTIC_2D: (f64, f64) = (7e-5, 1e-3);
const QUINTIC_3D: (f64, f64) = (2e-4, 3e-4);
const WENDLAND_2D: (f64, f64) = (1.6e-2, 4e-2);
const WENDLAND_3D: (f64, f64) = (1.5e-2, 3.2e-2);
const CUBIC_2D: (f64, f64) = (8e-5, 1.6e-2);
const CUBIC_3D: (f64, f64) = (4.2e-3, 1e-2);

#[test]
fn papers_printed_3d_quintic_constant_is_rejected() {
    // Nair & Tomar (2015), below Eq. 27, print α₃ = 3/(359π). Integrating the kernel with that
    // constant gives ∫W dV = 1.0028, far outside the 1e-8 normalisation tolerance; 1/(120π) gives 1.
    let k = QuinticSpline::<sph_core::D3>::new(1.0);
    let ours = integrate::<sph_core::D3>(&k);
    let printed = ours * (3.0 / (359.0 * PI)) / QuinticSpline::<sph_core::D3>::sigma();
    assert!((ours - 1.0).abs() < 1e-12);
    assert!(
        (printed - 1.0).abs() > 2e-3,
        "printed constant integrates to {printed}"
    );
    // The 2D constant 7/(478π) as printed is right.
    let k2 = QuinticSpline::<sph_core::D2>::new(1.0);
    assert!((integrate::<sph_core::D2>(&k2) - 1.0).abs() < 1e-12);
}
