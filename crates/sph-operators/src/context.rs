use rayon::prelude::*;
use sph_core::{Dim, Periodic};
use sph_kernels::Kernel;
use sph_neighbors::NeighborList;

/// What every operator reads: particle positions and volumes, the neighbour lists and the kernel.
///
/// `neighbors` must be the self-join of `positions` with radius ≥ the kernel support (each row
/// may include the particle itself; zero-distance pairs contribute nothing to derivatives).
#[derive(Clone, Copy, Debug)]
pub struct SphContext<'a, D: Dim, K: Kernel<D>> {
    /// Positions `x_i`.
    pub positions: &'a [D::Vector],
    /// Volumes `V_i = m_i / ρ_i`.
    pub volumes: &'a [f64],
    /// Neighbour lists (CSR), one row per particle.
    pub neighbors: &'a NeighborList,
    /// Smoothing kernel.
    pub kernel: &'a K,
    /// Periodic axes, if any: pair vectors are then minimum images (see [`SphContext::pair`]).
    pub periodic: Option<Periodic<D>>,
}

impl<'a, D: Dim, K: Kernel<D>> SphContext<'a, D, K> {
    /// Bundles the inputs; panics if the slices and neighbour list disagree on the particle count
    /// (a programming error, not a data error).
    pub fn new(
        positions: &'a [D::Vector],
        volumes: &'a [f64],
        neighbors: &'a NeighborList,
        kernel: &'a K,
    ) -> Self {
        assert_eq!(positions.len(), volumes.len(), "one volume per particle");
        assert_eq!(
            positions.len(),
            neighbors.len(),
            "one neighbour row per particle"
        );
        Self {
            positions,
            volumes,
            neighbors,
            kernel,
            periodic: None,
        }
    }

    /// The same context on a periodic domain (`None`: not periodic).
    pub fn with_periodic(mut self, periodic: Option<Periodic<D>>) -> Self {
        self.periodic = periodic;
        self
    }

    /// The pair vector `x_ij = x_i − x_j` from `x_i` to neighbour `j`, as the minimum image
    /// across periodic axes when the domain has any.
    #[inline(always)]
    pub fn pair(&self, xi: D::Vector, j: usize) -> D::Vector {
        let d = xi - self.positions[j];
        match &self.periodic {
            None => d,
            Some(p) => p.minimum_image(d),
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True if there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Neighbours of particle `i` as `usize` indices.
    #[inline(always)]
    pub fn neighbors_of(&self, i: usize) -> impl Iterator<Item = usize> + 'a {
        self.neighbors.row(i).iter().map(|&j| j as usize)
    }
}

/// The regulariser `η² = (0.01 h)²` of `F_ij = x_ij·∇W_ij / (r² + η²)` (paper, below Eq. 26).
#[inline(always)]
pub fn laplacian_regulariser(h: f64) -> f64 {
    (0.01 * h) * (0.01 * h)
}

/// `F_ij = x_ij·∇W_ij / (r_ij² + (0.01h)²)` (paper, below Eq. 26): the scalar kernel factor of
/// the Morris Laplacian and the Eq. 25 Hessian. `F_ij ≤ 0`; zero for `x_ij = 0`.
#[inline(always)]
pub fn pair_f<D: Dim, K: Kernel<D>>(kernel: &K, x_ij: D::Vector) -> f64 {
    use sph_core::VectorOps;
    x_ij.dot(kernel.grad_w(x_ij)) / (x_ij.length_squared() + laplacian_regulariser(kernel.h()))
}

/// Particles per rayon work item.
pub(crate) const MIN_LEN: usize = 256;

/// Sets `out[i] = f(i)` for every particle, in parallel.
#[inline]
pub(crate) fn gather<T: Send>(out: &mut [T], f: impl Fn(usize) -> T + Sync + Send) {
    out.par_iter_mut()
        .enumerate()
        .with_min_len(MIN_LEN)
        .for_each(|(i, o)| *o = f(i));
}
