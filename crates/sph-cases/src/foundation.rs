//! Checks of the foundation layers against exact values: kernel normalisation and
//! operator exactness on linear fields, in 2D and 3D. They take milliseconds and guard every
//! validation run against a broken constant.

use crate::Check;
use sph_core::testing::{SplitMix64, lattice};
use sph_core::{D2, D3, Dim, MatrixOps, VectorOps};
use sph_kernels::{Kernel, KernelKind};
use sph_neighbors::{CellGrid, NeighborList, NeighborSearch};
use sph_operators::{SphContext, correction_matrices, divergence, hessian, laplacian};

/// All foundation checks, both dimensions.
pub fn checks() -> Vec<Check> {
    let mut out = Vec::new();
    dim_checks::<D2>(&mut out);
    dim_checks::<D3>(&mut out);
    out
}

fn dim_checks<D: Dim>(out: &mut Vec<Check>) {
    for kind in KernelKind::ALL {
        let k = kind.build::<D>(1.0);
        out.push(Check::new(
            "kernels",
            format!("{} {}D ∫W dV", kind.name(), D::DIM),
            integrate_radial::<D>(&k),
            1.0,
            1e-8,
            "exact normalisation",
        ));
    }
    // Renormalised divergence of a linear field on a 10 %-perturbed lattice: exact.
    let dx = 0.1;
    let kernel = KernelKind::QuinticSpline.build::<D>(1.3 * dx);
    let mut pts = lattice::<D>(if D::DIM == 2 { 17 } else { 11 }, dx);
    let mut rng = SplitMix64::new(1);
    for p in pts.iter_mut() {
        *p += rng.vector::<D>(-0.1 * dx, 0.1 * dx);
    }
    let vols = vec![dx.powi(D::DIM as i32); pts.len()];
    let mut grid = CellGrid::<D>::new();
    let mut nl = NeighborList::new();
    if grid.build(&pts, kernel.support_radius()).is_err() {
        return;
    }
    grid.query(&pts, &mut nl);
    let ctx = SphContext::new(&pts, &vols, &nl, &kernel);
    let g = D::Matrix::from_fn(|i, j| (i as f64 + 1.0) * if i == j { 1.0 } else { 0.5 });
    let u: Vec<D::Vector> = pts.iter().map(|x| g * *x).collect();
    let mut l = vec![D::Matrix::ZERO; pts.len()];
    correction_matrices(&ctx, 1e-12, f64::INFINITY, &mut l);
    let mut div = vec![0.0; pts.len()];
    divergence(&ctx, &u, Some(&l), &mut div);
    let worst = div
        .iter()
        .map(|d| (d - g.trace()).abs())
        .fold(0.0, f64::max);
    out.push(Check::new(
        "operators",
        format!("renormalised ∇·u, linear u, {} max error", D::NAME),
        worst,
        0.0,
        1e-10,
        "exact for linear fields",
    ));
    // The trace of the Hessian must equal the Laplacian (pins the (d+2) coefficient of Eq. 25).
    let f: Vec<f64> = pts.iter().map(|x| x.length_squared().cos()).collect();
    let mut h = vec![D::Matrix::ZERO; pts.len()];
    let mut lap = vec![0.0; pts.len()];
    hessian(&ctx, &f, &mut h);
    laplacian(&ctx, &f, &mut lap);
    let worst = h
        .iter()
        .zip(&lap)
        .map(|(h, l)| (h.trace() - l).abs() / l.abs().max(1.0))
        .fold(0.0, f64::max);
    out.push(Check::new(
        "operators",
        format!("tr(Hessian) − Laplacian, {}", D::NAME),
        worst,
        0.0,
        1e-10,
        "identity of Eq. 25 with coefficient d+2",
    ));
}

/// `∫ W dV` by 12-point Gauss–Legendre quadrature on each unit-`q` spline piece.
fn integrate_radial<D: Dim>(k: &impl Kernel<D>) -> f64 {
    // Nodes and weights of 12-point Gauss–Legendre on [−1, 1] (positive half).
    const X: [f64; 6] = [
        0.125_233_408_511_468_9,
        0.367_831_498_998_180_2,
        0.587_317_954_286_617_4,
        0.769_902_674_194_304_7,
        0.904_117_256_370_474_9,
        0.981_560_634_246_719_3,
    ];
    const W: [f64; 6] = [
        0.249_147_045_813_402_8,
        0.233_492_536_538_354_8,
        0.203_167_426_723_065_9,
        0.160_078_328_543_346_2,
        0.106_939_325_995_318_4,
        0.047_175_336_386_511_8,
    ];
    let h = k.h();
    let pieces = (k.support_radius() / h).round() as usize;
    let shell = |r: f64| {
        if D::DIM == 2 {
            2.0 * std::f64::consts::PI * r
        } else {
            4.0 * std::f64::consts::PI * r * r
        }
    };
    let mut sum = 0.0;
    for p in 0..pieces {
        let (a, b) = (p as f64 * h, (p + 1) as f64 * h);
        for (x, w) in X.iter().zip(W) {
            for s in [-1.0, 1.0] {
                let r = 0.5 * (a + b) + 0.5 * (b - a) * s * x;
                sum += 0.5 * (b - a) * w * shell(r) * k.w(r);
            }
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    #[test]
    fn all_foundation_checks_pass() {
        let checks = super::checks();
        assert!(checks.len() >= 10);
        for c in &checks {
            assert!(c.passed(), "{c:?}");
        }
    }
}
