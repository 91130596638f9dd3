//! Pressure-equation assembly on perturbed lattices (PPE and DG,
//! `pressure/assemble_<eq>[_cached]/<dim>/<n>`; `_cached` with the kernel's gradient factors
//! attached, as the step runs it), and each solver on the assembled matrices of the paper's
//! drops after one step (`pressure/solve_<solver>/<dim>/<n>`).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use dgsph_benches::{Block, drop_scene};
use sph_cases::CaseKind;
use sph_cases::drop::initial;
use sph_core::{D2, D3, Dim, MatrixOps, VectorOps};
use sph_kernels::QuinticSpline;
use sph_neighbors::{CellGrid, NeighborList, NeighborSearch};
use sph_operators::{SphContext, free_surface_indicator, grad_factors};
use sph_pressure::{
    AnySolver, CsrMatrix, CsrSystem, DgHessian, LinearSolver, MeanZeroGauge, SolveParams,
    SolverKind, assemble_dg, assemble_ppe,
};
use std::hint::black_box;

fn assembly<D: Dim>(c: &mut Criterion, sizes: &[usize]) {
    let mut group = c.benchmark_group("pressure");
    group.sample_size(10);
    for &n in sizes {
        let block = Block::<D>::new(n);
        let (pts, ones, ctx) = (&block.pts, &block.ones, block.ctx());
        let n = pts.len();
        let dirichlet: Vec<bool> = block
            .div_r
            .iter()
            .map(|d| *d < 0.75 * D::DIM as f64)
            .collect();
        let src: Vec<f64> = pts.iter().map(|x| x.get(0) * 1e-3).collect();
        let a: Vec<D::Matrix> = pts
            .iter()
            .map(|x| D::Matrix::IDENTITY + D::Matrix::outer(*x, *x) * 1e-6)
            .collect();
        let mut m = CsrMatrix::default();
        let mut rhs = vec![0.0; n];
        // The step attaches the kernel's gradient factors, computed once per step, to the
        // context its passes share: the `_cached` variants time the assembly as it runs there.
        let mut factors = Vec::new();
        grad_factors(&ctx, &mut factors);
        let cached = block.ctx().with_grad_factors(&factors);
        for (suffix, ctx) in [("", &ctx), ("_cached", &cached)] {
            group.bench_function(
                BenchmarkId::new(format!("assemble_ppe{suffix}/{}", D::NAME), n),
                |b| {
                    b.iter(|| {
                        assemble_ppe(
                            ctx,
                            ones,
                            ones,
                            &src,
                            1e-3,
                            &dirichlet,
                            None,
                            rhs.len(),
                            &mut m,
                            &mut rhs,
                        )
                        .unwrap();
                        black_box(m.values[0])
                    })
                },
            );
            for (name, h) in [
                ("assemble_dg_eq25", DgHessian::Eq25),
                ("assemble_dg_fit", DgHessian::QuadraticFit),
            ] {
                let id = BenchmarkId::new(format!("{name}{suffix}/{}", D::NAME), n);
                group.bench_function(id, |b| {
                    b.iter(|| {
                        assemble_dg(
                            ctx,
                            ones,
                            &a,
                            &src,
                            1e-3,
                            h,
                            &dirichlet,
                            None,
                            rhs.len(),
                            &mut m,
                            &mut rhs,
                        )
                        .unwrap();
                        black_box(m.values[0])
                    })
                });
            }
        }
    }
    group.finish();
}

/// The drop's matrices after one step of each equation, solved by each solver from zero.
fn solvers<D: Dim>(c: &mut Criterion, case: CaseKind, dx: f64) {
    let mut group = c.benchmark_group("pressure");
    group.sample_size(10);
    let scene = drop_scene(case, dx);
    let (particles, _) = initial::<D>(&scene);
    let pts = &particles.positions;
    let n = pts.len();
    let kernel = QuinticSpline::<D>::new(1.3 * dx);
    let mut grid = CellGrid::<D>::new();
    grid.build(pts, 3.0 * 1.3 * dx).unwrap();
    let mut nl = NeighborList::new();
    grid.query(pts, &mut nl);
    let vols = vec![dx.powi(D::DIM as i32); n];
    let ctx = SphContext::new(pts, &vols, &nl, &kernel);
    let mut div_r = vec![0.0; n];
    free_surface_indicator(&ctx, &mut div_r);
    let dirichlet: Vec<bool> = div_r.iter().map(|d| *d < 0.75 * D::DIM as f64).collect();
    // Source of the PC step: ∇·u* ≈ −Δt tr(G²) in the bulk.
    let src = vec![-2e-4 * 2e4; n];
    let mut m = CsrMatrix::default();
    let mut rhs = vec![0.0; n];
    let ones = vec![1.0; n];
    assemble_ppe(
        &ctx,
        &vols,
        &ones,
        &src,
        2e-4,
        &dirichlet,
        None,
        rhs.len(),
        &mut m,
        &mut rhs,
    )
    .unwrap();
    let sys = CsrSystem {
        offsets: nl.offsets(),
        cols: nl.indices(),
        values: &m.values,
        rhs: &rhs,
        border: None,
    };
    let params = SolveParams::default();
    for kind in [
        SolverKind::BicgstabJacobi,
        SolverKind::BicgstabIlu0,
        SolverKind::BicgstabAmg,
        SolverKind::SparseLu,
    ] {
        if kind == SolverKind::SparseLu && D::DIM == 3 && n > 20_000 {
            continue;
        }
        let mut solver = AnySolver::new(kind);
        let mut x = vec![0.0; n];
        group.bench_function(
            BenchmarkId::new(format!("solve_{kind:?}/{}", D::NAME), n),
            |b| {
                b.iter(|| {
                    x.fill(0.0);
                    black_box(solver.solve(&sys, &mut x, &params).unwrap().iterations)
                })
            },
        );
    }
    // The same matrix without Dirichlet rows under the mean-zero gauge: the closed-domain
    // (cavity) system, one dense border row and column.
    let mut closed = CsrMatrix::default();
    let none = vec![false; n];
    assemble_ppe(
        &ctx,
        &vols,
        &ones,
        &src,
        2e-4,
        &none,
        None,
        rhs.len(),
        &mut closed,
        &mut rhs,
    )
    .unwrap();
    // A right-hand side with a smooth solution (the constant source above is almost entirely
    // the incompatible part, which the gauge removes without iterating).
    let x_star: Vec<f64> = pts
        .iter()
        .map(|x| {
            let a = x.to_array3();
            (3.0 * a[0]).cos() + (2.0 * a[1]).sin() + a[2]
        })
        .collect();
    closed.matvec(nl.offsets(), nl.indices(), &x_star, &mut rhs);
    let sys = CsrSystem {
        offsets: nl.offsets(),
        cols: nl.indices(),
        values: &closed.values,
        rhs: &rhs,
        border: None,
    };
    for kind in [SolverKind::BicgstabJacobi, SolverKind::BicgstabAmg] {
        let mut solver = AnySolver::new(kind);
        let mut gauge = MeanZeroGauge::default();
        let mut x = vec![0.0; n];
        group.bench_function(
            BenchmarkId::new(format!("solve_closed_{kind:?}/{}", D::NAME), n),
            |b| {
                b.iter(|| {
                    x.fill(0.0);
                    black_box(
                        gauge
                            .solve(&mut solver, &sys, n, &mut x, &params)
                            .unwrap()
                            .iterations,
                    )
                })
            },
        );
    }
    group.finish();
}

fn pressure(c: &mut Criterion) {
    assembly::<D2>(c, &[10_000, 100_000]);
    assembly::<D3>(c, &[10_000, 100_000]);
    solvers::<D2>(c, CaseKind::EllipticalDrop, 0.025);
    solvers::<D2>(c, CaseKind::EllipticalDrop, 0.0125);
    solvers::<D3>(c, CaseKind::SpheroidDrop, 0.05);
}

criterion_group!(benches, pressure);
criterion_main!(benches);
