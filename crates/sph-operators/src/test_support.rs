//! Lattice fixtures for the operator tests.

use crate::SphContext;
use sph_core::testing::{SplitMix64, lattice};
use sph_core::{Dim, VectorOps};
use sph_kernels::{AnyKernel, Kernel, KernelKind};
use sph_neighbors::{CellGrid, NeighborList, NeighborSearch};

/// A block of particles on a regular lattice (optionally perturbed), with its neighbour lists.
pub struct Lattice<D: Dim> {
    pub dx: f64,
    pub positions: Vec<D::Vector>,
    pub volumes: Vec<f64>,
    pub neighbors: NeighborList,
    pub kernel: AnyKernel<D>,
}

impl<D: Dim> Lattice<D> {
    /// Lattice with `h = h_over_dx · dx`, each particle moved by up to `jitter · dx` per axis
    /// (seeded), and wide enough that the centre region has full kernel support.
    pub fn new(kind: KernelKind, h_over_dx: f64, jitter: f64) -> Self {
        // In 3D keep the block small (the centre plus one support on each side, plus 2).
        Self::with_margin(kind, h_over_dx, jitter, if D::DIM == 2 { 9 } else { 3 })
    }

    /// As [`Lattice::new`], with `2 reach + margin` particles per side (`reach`: the support in
    /// spacings), for operators applied twice (the centre needs two supports of full support).
    pub fn with_margin(kind: KernelKind, h_over_dx: f64, jitter: f64, margin: usize) -> Self {
        let dx = 0.1;
        let kernel = kind.build::<D>(h_over_dx * dx);
        let reach = (kernel.support_radius() / dx).ceil() as usize;
        let per_side = 2 * reach + margin;
        let mut positions = lattice::<D>(per_side, dx);
        let mut rng = SplitMix64::new(42);
        for x in positions.iter_mut() {
            *x += rng.vector::<D>(-jitter * dx, jitter * dx);
        }
        let volumes = vec![dx.powi(D::DIM as i32); positions.len()];
        let mut grid = CellGrid::<D>::new();
        grid.build(&positions, kernel.support_radius()).unwrap();
        let mut neighbors = NeighborList::new();
        grid.query(&positions, &mut neighbors);
        Self {
            dx,
            positions,
            volumes,
            neighbors,
            kernel,
        }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn with_ctx<R>(&self, f: impl FnOnce(&SphContext<'_, D, AnyKernel<D>>) -> R) -> R {
        f(&SphContext::new(
            &self.positions,
            &self.volumes,
            &self.neighbors,
            &self.kernel,
        ))
    }

    /// Index of the particle nearest the origin (the lattice centre).
    pub fn centre(&self) -> usize {
        (0..self.len())
            .min_by(|&a, &b| {
                self.positions[a]
                    .length()
                    .total_cmp(&self.positions[b].length())
            })
            .unwrap()
    }

    /// Particles whose whole kernel support (plus a jitter margin) lies inside the block, so
    /// that their neighbourhood is complete.
    pub fn interior(&self) -> Vec<usize> {
        let half = self
            .positions
            .iter()
            .map(|x| (0..D::DIM).map(|k| x.get(k).abs()).fold(0.0, f64::max))
            .fold(0.0, f64::max);
        let limit = half - self.kernel.support_radius() - 0.5 * self.dx;
        (0..self.len())
            .filter(|&i| (0..D::DIM).all(|k| self.positions[i].get(k).abs() <= limit))
            .collect()
    }
}
