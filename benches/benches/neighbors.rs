//! Neighbour search: cell grid vs kiddo kd-tree, build + self-join query, `neighbors/<kind>/<dim>/<n>`,
//! on shuffled particles (the worst case for locality).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use dgsph_benches::{RADIUS, particles_shuffled};
use sph_core::{D2, D3, Dim};
use sph_neighbors::{AnySearch, NeighborList, NeighborSearch, SearchKind};
use std::hint::black_box;

fn bench_dim<D: Dim>(c: &mut Criterion, sizes: &[usize]) {
    let mut group = c.benchmark_group("neighbors");
    group.sample_size(10);
    for &n in sizes {
        let pts = particles_shuffled::<D>(n);
        for (name, kind) in [
            ("cell_grid", SearchKind::CellGrid),
            ("kd_tree", SearchKind::KdTree),
        ] {
            let mut search = AnySearch::<D>::new(kind);
            let mut list = NeighborList::new();
            group.bench_with_input(
                BenchmarkId::new(format!("{name}/{}", D::NAME), n),
                &pts,
                |b, pts| {
                    b.iter(|| {
                        search.build(pts, RADIUS).unwrap();
                        search.query(pts, &mut list);
                        black_box(list.nnz())
                    })
                },
            );
        }
    }
    group.finish();
}

fn neighbors(c: &mut Criterion) {
    bench_dim::<D2>(c, &[10_000, 100_000, 1_000_000]);
    bench_dim::<D3>(c, &[10_000, 100_000]);
}

criterion_group!(benches, neighbors);
criterion_main!(benches);
