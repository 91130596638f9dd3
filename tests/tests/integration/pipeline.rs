//! Kernel → neighbour search → operators, with both search backends: the operator results must
//! be bitwise identical whichever backend built the (identical) neighbour lists.

use sph_core::testing::random_cloud;
use sph_core::{D2, D3, Dim, MatrixOps, VectorOps};
use sph_kernels::{Kernel, KernelKind};
use sph_neighbors::{AnySearch, NeighborList, NeighborSearch, SearchKind};
use sph_operators::{SphContext, correction_matrices, divergence, hessian};

fn pipeline<D: Dim>(kind: SearchKind) -> (Vec<f64>, Vec<D::Matrix>) {
    let dx = 0.05;
    let n = if D::DIM == 2 { 1600 } else { 3000 };
    let side = dx * (n as f64).powf(1.0 / D::DIM as f64);
    let pts = random_cloud::<D>(n, 0.0, side, 77);
    let kernel = KernelKind::WendlandC2.build::<D>(1.3 * dx);
    let mut search = AnySearch::<D>::new(kind);
    search.build(&pts, kernel.support_radius()).unwrap();
    let mut nl = NeighborList::new();
    search.query(&pts, &mut nl);
    let vols = vec![dx.powi(D::DIM as i32); n];
    let ctx = SphContext::new(&pts, &vols, &nl, &kernel);
    let u: Vec<D::Vector> = pts
        .iter()
        .map(|x| D::Vector::from_fn(|k| (x.get(k) * 3.0).sin()))
        .collect();
    let f: Vec<f64> = pts.iter().map(|x| x.length_squared()).collect();
    let mut l = vec![D::Matrix::ZERO; n];
    correction_matrices(&ctx, 1e-9, f64::INFINITY, &mut l);
    let mut div = vec![0.0; n];
    divergence(&ctx, &u, Some(&l), &mut div);
    let mut h = vec![D::Matrix::ZERO; n];
    hessian(&ctx, &f, &mut h);
    (div, h)
}

fn backends_agree<D: Dim>() {
    let a = pipeline::<D>(SearchKind::CellGrid);
    let b = pipeline::<D>(SearchKind::KdTree);
    assert_eq!(a, b);
    assert!(a.0.iter().all(|d| d.is_finite()));
}

#[test]
fn backends_agree_d2() {
    backends_agree::<D2>();
}

#[test]
fn backends_agree_d3() {
    backends_agree::<D3>();
}
