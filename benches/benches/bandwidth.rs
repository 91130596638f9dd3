//! How close the sparse matrix–vector product comes to the machine's memory bandwidth, measured
//! in the same run: a STREAM-style triad `a = b + s·c` (Table 1 of McCalpin's STREAM, 24 bytes
//! per element counted) over arrays far larger than the caches, `bandwidth/triad/<n>`, and the
//! CSR product `y = A x` of our pressure matrix (a 2D perturbed lattice, quintic, h = 1.3 dx: 45
//! entries per row), `bandwidth/matvec/<n>`, which must at least read the values (8 bytes), the
//! column indices (4 bytes), the row offsets (8 bytes per row) and `x`, and write `y` (8 bytes per
//! row each). Criterion prints both as bytes per second; their ratio is the fraction of the
//! bandwidth the product reaches. Threads: `RAYON_NUM_THREADS`.
//!
//! `cargo bench -p dgsph-benches --bench bandwidth`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use dgsph_benches::{H, particles, self_join};
use rayon::prelude::*;
use sph_core::D2;
use sph_kernels::QuinticSpline;
use sph_operators::SphContext;
use sph_pressure::{CsrMatrix, assemble_ppe};
use std::hint::black_box;

fn triad(c: &mut Criterion) {
    let mut group = c.benchmark_group("bandwidth");
    group.sample_size(20);
    let n = 1 << 24; // 3 arrays of 128 MiB
    let b = vec![1.0f64; n];
    let cc = vec![2.0f64; n];
    let mut a = vec![0.0f64; n];
    group.throughput(Throughput::Bytes(24 * n as u64));
    group.bench_function(BenchmarkId::new("triad", n), |bench| {
        bench.iter(|| {
            a.par_iter_mut()
                .zip(b.par_iter().zip(cc.par_iter()))
                .with_min_len(1 << 14)
                .for_each(|(a, (b, c))| *a = b + 3.0 * c);
            black_box(a[n / 2])
        })
    });
    group.finish();
}

fn matvec(c: &mut Criterion) {
    let mut group = c.benchmark_group("bandwidth");
    group.sample_size(20);
    {
        let pts = particles::<D2>(1_000_000);
        let nl = self_join::<D2>(&pts);
        let kernel = QuinticSpline::<D2>::new(H);
        let n = pts.len();
        let ones = vec![1.0; n];
        let ctx = SphContext::new(&pts, &ones, &nl, &kernel);
        let src = vec![1.0; n];
        let dirichlet = vec![false; n];
        let mut m = CsrMatrix::default();
        let mut rhs = vec![0.0; n];
        assemble_ppe(
            &ctx,
            &ones,
            &ones,
            &src,
            1.0,
            &dirichlet,
            None,
            rhs.len(),
            &mut m,
            &mut rhs,
        )
        .expect("assembly of the bench matrix");
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut y = vec![0.0; n];
        let nnz = nl.indices().len() as u64;
        group.throughput(Throughput::Bytes(nnz * 12 + n as u64 * 24));
        group.bench_function(BenchmarkId::new("matvec", n), |bench| {
            bench.iter(|| {
                m.matvec(nl.offsets(), nl.indices(), &x, &mut y);
                black_box(y[n / 2])
            })
        });
    }
    group.finish();
}

criterion_group!(benches, triad, matvec);
criterion_main!(benches);
