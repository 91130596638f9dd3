use crate::context::{SphContext, gather};
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;
use sph_neighbors::NeighborList;

/// Density by summation, paper Eq. (31): `ρ_i = Σ_j m_j W(|x_i − x_j|, h)` (the sum includes
/// `j = i`).
pub fn density_summation<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    masses: &[f64],
    out: &mut [f64],
) {
    assert_eq!(masses.len(), ctx.len());
    assert_eq!(out.len(), ctx.len());
    gather(out, |i| {
        let xi = ctx.positions[i];
        ctx.neighbors_of(i)
            .map(|j| masses[j] * ctx.kernel.w(ctx.pair(xi, j).length()))
            .sum()
    });
}

/// Density sampled at arbitrary probe points, paper Eq. (31): `ρ̂_a = Σ_b m_b W(|r_a − r_b|, h)`,
/// `a` a probe point and `b` the particles.
///
/// `probe_neighbors` must list, for each probe, the particles within the kernel support (from
/// [`NeighborSearch::query`](sph_neighbors::NeighborSearch::query) on the particle index). This is
/// the density-error measure of the paper's cavity study (uniform array of probe points).
pub fn density_at_points<D: Dim, K: Kernel<D>>(
    probes: &[D::Vector],
    probe_neighbors: &NeighborList,
    positions: &[D::Vector],
    masses: &[f64],
    kernel: &K,
    out: &mut [f64],
) {
    assert_eq!(probes.len(), probe_neighbors.len());
    assert_eq!(out.len(), probes.len());
    assert_eq!(masses.len(), positions.len());
    gather(out, |a| {
        let xa = probes[a];
        probe_neighbors
            .row(a)
            .iter()
            .map(|&b| masses[b as usize] * kernel.w((xa - positions[b as usize]).length()))
            .sum()
    });
}
