//! One operator pass on a prepared neighbour list: the renormalised divergence (correction
//! matrices + divergence) and the Morris Laplacian, `operators/<op>/<dim>/<n>`.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use dgsph_benches::{H, particles, self_join};
use sph_core::{D2, D3, Dim, MatrixOps, VectorOps};
use sph_kernels::QuinticSpline;
use sph_operators::{SphContext, correction_matrices, divergence, laplacian};
use std::hint::black_box;

fn bench_dim<D: Dim>(c: &mut Criterion, sizes: &[usize]) {
    let mut group = c.benchmark_group("operators");
    group.sample_size(10);
    for &n in sizes {
        let pts = particles::<D>(n);
        let nl = self_join::<D>(&pts);
        let kernel = QuinticSpline::<D>::new(H);
        let vols = vec![1.0; pts.len()];
        let ctx = SphContext::new(&pts, &vols, &nl, &kernel);
        let u: Vec<D::Vector> = pts.iter().map(|x| *x * -0.5).collect();
        let f: Vec<f64> = pts.iter().map(|x| x.length_squared()).collect();
        let mut l = vec![D::Matrix::ZERO; pts.len()];
        let mut div = vec![0.0; pts.len()];
        let mut lap = vec![0.0; pts.len()];
        group.bench_function(
            BenchmarkId::new(format!("divergence_renormalised/{}", D::NAME), n),
            |b| {
                b.iter(|| {
                    correction_matrices(&ctx, 1e-12, f64::INFINITY, &mut l);
                    divergence(&ctx, &u, Some(&l), &mut div);
                    black_box(div[0])
                })
            },
        );
        group.bench_function(BenchmarkId::new(format!("laplacian/{}", D::NAME), n), |b| {
            b.iter(|| {
                laplacian(&ctx, &f, &mut lap);
                black_box(lap[0])
            })
        });
    }
    group.finish();
}

fn operators(c: &mut Criterion) {
    bench_dim::<D2>(c, &[10_000, 100_000, 1_000_000]);
    bench_dim::<D3>(c, &[10_000, 100_000]);
}

criterion_group!(benches, operators);
criterion_main!(benches);
