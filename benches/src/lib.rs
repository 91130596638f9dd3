//! Shared fixtures of the dgsph criterion benches: seeded, lattice-like particle sets of a given
//! size with the paper's resolution ratio `h = 1.3 dx` and the quintic support `3h`.

/// hypre through FFI, for the multigrid comparison: the workspace's only unsafe code, behind
/// the `hypre` feature.
#[cfg(feature = "hypre")]
#[allow(unsafe_code)]
pub mod hypre;

use sph_cases::{CaseKind, Scene};
use sph_core::testing::{SplitMix64, lattice};
use sph_core::{Dim, VectorOps};
use sph_kernels::QuinticSpline;
use sph_neighbors::{CellGrid, NeighborList, NeighborSearch};
use sph_operators::{SphContext, free_surface_indicator};

/// A perturbed lattice of about `n` particles (spacing `dx = 1`, jitter ±10 %), seeded, in
/// lattice (x-fastest) order: the memory order a simulation keeps its particles in.
pub fn particles<D: Dim>(n: usize) -> Vec<D::Vector> {
    let per_side = (n as f64).powf(1.0 / D::DIM as f64).round() as usize;
    let mut pts = lattice::<D>(per_side, 1.0);
    let mut rng = SplitMix64::new(2024);
    for p in pts.iter_mut() {
        *p += rng.vector::<D>(-0.1, 0.1);
    }
    pts
}

/// [`particles`] in random order: the worst case for memory locality.
pub fn particles_shuffled<D: Dim>(n: usize) -> Vec<D::Vector> {
    let mut pts = particles::<D>(n);
    let mut rng = SplitMix64::new(2025);
    for i in (1..pts.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        pts.swap(i, j);
    }
    pts
}

/// Smoothing length for `dx = 1`.
pub const H: f64 = 1.3;

/// Quintic support radius `3h`.
pub const RADIUS: f64 = 3.0 * H;

/// Mean of a field, to keep results observable.
pub fn checksum<V: VectorOps>(v: &[V]) -> f64 {
    v.iter().map(|x| x.get(0)).sum()
}

/// The self-join neighbour list of `pts` at [`RADIUS`] (cell grid).
pub fn self_join<D: Dim>(pts: &[D::Vector]) -> NeighborList {
    let mut grid = CellGrid::<D>::new();
    grid.build(pts, RADIUS).expect("finite bench particles");
    let mut nl = NeighborList::new();
    grid.query(pts, &mut nl);
    nl
}

/// A one-step scene of the paper's drop (`case`) at spacing `dx`, Δt = 2e-4, default threshold.
pub fn drop_scene(case: CaseKind, dx: f64) -> Scene {
    Scene::paper_drop(case, dx, 2e-4, 2e-4)
}

/// The pressure benches' block of water: [`particles`] with their [`self_join`], the quintic
/// kernel at [`H`], unit volumes and the free-surface indicator `∇·r` of every particle.
pub struct Block<D: Dim> {
    /// Positions.
    pub pts: Vec<D::Vector>,
    /// Self-join neighbour list (the matrices' sparsity).
    pub nl: NeighborList,
    /// Quintic spline, `h` = [`H`].
    pub kernel: QuinticSpline<D>,
    /// Unit volumes (and densities).
    pub ones: Vec<f64>,
    /// `∇·r` per particle (free surface where it is small).
    pub div_r: Vec<f64>,
}

impl<D: Dim> Block<D> {
    /// A block of about `n` particles.
    pub fn new(n: usize) -> Self {
        let pts = particles::<D>(n);
        let nl = self_join::<D>(&pts);
        let kernel = QuinticSpline::<D>::new(H);
        let ones = vec![1.0; pts.len()];
        let mut div_r = vec![0.0; pts.len()];
        free_surface_indicator(&SphContext::new(&pts, &ones, &nl, &kernel), &mut div_r);
        Self {
            pts,
            nl,
            kernel,
            ones,
            div_r,
        }
    }

    /// The operator context of the block.
    pub fn ctx(&self) -> SphContext<'_, D, QuinticSpline<D>> {
        SphContext::new(&self.pts, &self.ones, &self.nl, &self.kernel)
    }
}
