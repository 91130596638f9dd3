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

/// The Shepard sum `Σ_k V W(|k| Δx, h)` of a particle inside an infinite perfect lattice of
/// spacing `Δx = V^{1/D}` (`k` over `ℤ^D`, the particle itself included): what
/// [`kernel_sum_excess`] measures against. Near 1; the difference is the kernel's lattice error
/// at `h/Δx`.
pub fn lattice_kernel_sum<D: Dim, K: Kernel<D>>(kernel: &K, volume: f64) -> f64 {
    over_lattice::<D, K>(kernel, volume, |x| kernel.w(x.length())) * volume
}

/// `Σ_k f(k Δx)` over the points of an infinite perfect lattice of spacing `Δx = V^{1/D}`
/// (`k` over `ℤ^D`, the origin included) within the kernel's support; `f` must vanish beyond it.
pub(crate) fn over_lattice<D: Dim, K: Kernel<D>>(
    kernel: &K,
    volume: f64,
    f: impl Fn(D::Vector) -> f64,
) -> f64 {
    let dx = volume.powf(1.0 / D::DIM as f64);
    let reach = (kernel.support_radius() / dx).ceil() as i64;
    let side = 2 * reach + 1;
    let points = side.pow(D::DIM as u32);
    (0..points)
        .map(|n| {
            let mut rest = n;
            let x = D::Vector::from_fn(|_| {
                let k = rest % side - reach;
                rest /= side;
                k as f64 * dx
            });
            f(x)
        })
        .sum::<f64>()
}

/// Relative excess of each particle's Shepard sum over a perfect lattice's,
/// `e_i = Σ_j V_j W_ij / S_lattice − 1` (`S_lattice` from [`lattice_kernel_sum`] at `volume`):
/// positive where the particles are packed closer than the lattice their volumes stand for, the
/// summation-density error `ρ̂_i/ρ̂_lattice − 1` of Eq. (31) for equal masses. `skip[i]`: write
/// 0 instead (particles whose support is cut by a free surface, where the sum measures the cut
/// and not the packing). Only the first `out.len()` particles are evaluated.
pub fn kernel_sum_excess<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    volume: f64,
    skip: &[bool],
    out: &mut [f64],
) {
    assert!(out.len() <= ctx.len(), "at most one output per particle");
    assert!(skip.len() >= out.len());
    let lattice = lattice_kernel_sum(ctx.kernel, volume);
    gather(out, |i| {
        if skip[i] {
            return 0.0;
        }
        let xi = ctx.positions[i];
        let sum: f64 = ctx
            .neighbors_of(i)
            .map(|j| ctx.volumes[j] * ctx.kernel.w(ctx.pair(xi, j).length()))
            .sum();
        sum / lattice - 1.0
    });
}
