use crate::Simulation;
use sph_core::{Dim, MatrixOps, VectorOps};

/// A dimension-free, read-only view of the particle state for output sinks (MCAP frames,
/// CSV dumps). 2D quantities are reported with a zero third component. Particle `i` is the same
/// particle in every frame of a run (for a [`Simulation`]: its index in the initial state,
/// whatever slot [`SimConfig::reorder_every`](crate::SimConfig) has moved it to).
pub trait Frame {
    /// Simulated time.
    fn time(&self) -> f64;
    /// Number of particles.
    fn len(&self) -> usize;
    /// True if there are no particles.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Spatial dimension.
    fn dim(&self) -> usize;
    /// Position of particle `i`.
    fn position(&self, i: usize) -> [f64; 3];
    /// Velocity of particle `i`.
    fn velocity(&self, i: usize) -> [f64; 3];
    /// Pressure of particle `i`.
    fn pressure(&self, i: usize) -> f64;
    /// Density of particle `i`.
    fn density(&self, i: usize) -> f64;
    /// Whether particle `i` was a free-surface (Dirichlet) particle in the last projection.
    fn free_surface(&self, i: usize) -> bool;
    /// det F of particle `i` over the last step (1 before the first step or without diagnostics).
    fn det_f(&self, i: usize) -> f64;
    /// Whether particle `i` is a wall particle (fixed, prescribed velocity) rather than fluid.
    fn wall(&self, i: usize) -> bool;
}

impl<D: Dim> Frame for Simulation<D> {
    fn time(&self) -> f64 {
        self.t
    }
    fn len(&self) -> usize {
        self.particles.len()
    }
    fn dim(&self) -> usize {
        D::DIM
    }
    fn position(&self, i: usize) -> [f64; 3] {
        self.particles.positions[self.slot(i)].to_array3()
    }
    fn velocity(&self, i: usize) -> [f64; 3] {
        self.particles.velocities[self.slot(i)].to_array3()
    }
    fn pressure(&self, i: usize) -> f64 {
        self.particles.pressures[self.slot(i)]
    }
    fn density(&self, i: usize) -> f64 {
        self.particles.densities[self.slot(i)]
    }
    fn free_surface(&self, i: usize) -> bool {
        self.engine
            .dirichlet
            .get(self.slot(i))
            .copied()
            .unwrap_or(false)
    }
    fn det_f(&self, i: usize) -> f64 {
        if self.step == 0 || !self.engine.config.diagnostics.det_f {
            return 1.0;
        }
        self.buf
            .det_f
            .get(self.slot(i))
            .map_or(1.0, |f| f.determinant())
    }
    fn wall(&self, i: usize) -> bool {
        i >= self.fluid_len()
    }
}
