//! Solid walls.

use rayon::prelude::*;
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;
use sph_operators::SphContext;
use thiserror::Error;

/// How walls are represented. Both models share this interface: wall particles are stored after
/// the fluid particles in the same [`ParticleSet`](sph_core::ParticleSet), take part in every
/// neighbour sum, have pressure unknowns in the pressure equation, and never move.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum WallModel {
    /// Fixed dummy particles (Adami, Hu & Adams 2012, J. Comput. Phys. 231, 7057): a few layers
    /// of particles on the initial lattice behind each wall.
    ///
    /// * divergence and `A = I + ∇(Δt u*)`: the
    ///   free-slip mirror `u_wall + S(ũ_w − u_wall)` of the extrapolated fluid velocity, see
    ///   [`Walls::mirror`] — the reflection consistent with the even pressure extension;
    /// * viscosity (no slip): `2 u_w − ũ_w`, with `ũ_w` the Shepard average of the fluid
    ///   velocities around the wall particle (Adami Eq. 22–23);
    /// * pressure: the extrapolation row `p_w = Σ_f p_f W_wf / Σ_f W_wf` (+ body-force term,
    ///   Adami Eq. 27), solved together with the fluid rows (see
    ///   `sph_pressure::assemble_wall_rows`).
    ///
    /// Because the wall pressures are unknowns of the same system, the discrete Laplacian (or DG
    /// Hessian) a fluid particle sees is the same operator whose gradient corrects its velocity:
    /// the projection removes the divergence next to walls and corners as it does in the bulk.
    #[default]
    DummyParticles,
}

/// Walls of a simulation: particles `first..n` of the particle set, their prescribed velocities,
/// and the box the fluid must stay in (penetration check).
#[derive(Clone, Debug, PartialEq)]
pub struct Walls<D: Dim> {
    /// The wall model.
    pub model: WallModel,
    /// Index of the first wall particle; the fluid particles are `0..first`.
    pub first: usize,
    /// Prescribed velocity of each wall particle (`n − first` entries).
    pub velocity: Vec<D::Vector>,
    /// Reflection of each wall particle's wall: `−1` along the axes normal to the wall(s) it
    /// sits behind, `+1` along the others (a corner block flips two axes).
    pub mirror: Vec<D::Vector>,
    /// Lower corner of the fluid container.
    pub lo: D::Vector,
    /// Upper corner of the fluid container.
    pub hi: D::Vector,
}

/// Inconsistent wall description.
#[derive(Debug, Error)]
pub enum WallError {
    /// `first + velocity.len()` differs from the particle count, or `mirror` from `velocity`.
    #[error("walls: {first} fluid particles + {walls} wall velocities ≠ {particles} particles")]
    Count {
        /// Fluid particles.
        first: usize,
        /// Wall velocities given.
        walls: usize,
        /// Particles in the set.
        particles: usize,
    },
    /// The particle set is invalid.
    #[error("walls: {0}")]
    Particles(#[from] sph_core::CoreError),
    /// The container box is empty or not finite.
    #[error("walls: the container box is empty or not finite")]
    Box,
}

impl<D: Dim> Walls<D> {
    /// How far `x` lies outside the container box: `max_k max(lo_k − x_k, x_k − hi_k, 0)`.
    fn outside(&self, x: D::Vector) -> f64 {
        (0..D::DIM)
            .map(|k| (self.lo.get(k) - x.get(k)).max(x.get(k) - self.hi.get(k)))
            .fold(0.0, f64::max)
    }

    /// Number of fluid particles outside the container box (each one has crossed a wall).
    pub fn penetrations(&self, positions: &[D::Vector]) -> usize {
        positions[..self.first]
            .iter()
            .filter(|x| self.outside(**x) > 0.0)
            .count()
    }

    /// How far the furthest fluid particle lies outside the container box (0 when none does).
    /// Tells a particle in the half-spacing gap
    /// between the wall line and the first wall layer (depth < Δp/2) from one that has passed
    /// the wall particles.
    pub fn max_intrusion(&self, positions: &[D::Vector]) -> f64 {
        positions[..self.first]
            .iter()
            .map(|x| self.outside(*x))
            .fold(0.0, f64::max)
    }

    /// No-slip (viscous) wall velocity, Adami et al. (2012) Eqs. (22)–(23):
    /// `u_w = 2 u_wall − ũ_w`, `ũ_w = Σ_f u_f W_wf / Σ_f W_wf` (fluid neighbours `f` from
    /// `ctx`, whose particles are this simulation's). Writes one entry per wall particle.
    pub fn no_slip_velocity<K: Kernel<D>>(
        &self,
        ctx: &SphContext<'_, D, K>,
        u: &[D::Vector],
        out: &mut [D::Vector],
    ) {
        self.map_shepard(ctx, u, out, |k, ut| self.velocity[k] * 2.0 - ut);
    }

    /// Free-slip (divergence) wall velocity: the fluid velocity extrapolated to the wall
    /// particle, its normal part reflected about the wall's: `u_w = u_wall + S_w (ũ_w − u_wall)`
    /// with `S_w` the particle's [`mirror`](Self::mirror). This is the reflection under which the
    /// velocity correction `−Δt∇p/ρ` of an even (Neumann) pressure extension is itself mirrored,
    /// so the divergence of the corrected field near a wall is the operator the pressure equation
    /// inverts (D·G ≈ L there too). A wall's tangential motion does not enter the divergence.
    pub(crate) fn free_slip_velocity<K: Kernel<D>>(
        &self,
        ctx: &SphContext<'_, D, K>,
        u: &[D::Vector],
        out: &mut [D::Vector],
    ) {
        self.map_shepard(ctx, u, out, |k, ut| {
            let w = self.velocity[k];
            let s = self.mirror[k];
            w + D::Vector::from_fn(|a| s.get(a) * (ut.get(a) - w.get(a)))
        });
    }

    /// `out[k] = f(k, ũ_k)` for each wall particle, with `ũ` the Shepard average of the fluid
    /// velocities around it (`u_wall` where it has no fluid neighbour).
    fn map_shepard<K: Kernel<D>>(
        &self,
        ctx: &SphContext<'_, D, K>,
        u: &[D::Vector],
        out: &mut [D::Vector],
        f: impl Fn(usize, D::Vector) -> D::Vector + Sync,
    ) {
        let nf = self.first;
        out.par_iter_mut()
            .enumerate()
            .with_min_len(256)
            .for_each(|(k, o)| {
                let xw = ctx.positions[nf + k];
                let (mut sum_w, mut sum_u) = (0.0, D::Vector::ZERO);
                for j in ctx.neighbors_of(nf + k) {
                    if j < nf {
                        let wij = ctx.kernel.w((xw - ctx.positions[j]).length());
                        sum_w += wij;
                        sum_u += u[j] * wij;
                    }
                }
                let ut = if sum_w > 0.0 {
                    sum_u * (1.0 / sum_w)
                } else {
                    self.velocity[k]
                };
                *o = f(k, ut);
            });
    }

    pub(crate) fn check(&self, particles: usize) -> Result<(), WallError> {
        if self.first + self.velocity.len() != particles || self.mirror.len() != self.velocity.len()
        {
            return Err(WallError::Count {
                first: self.first,
                walls: self.velocity.len(),
                particles,
            });
        }
        let ok = (0..D::DIM).all(|k| {
            let (a, b) = (self.lo.get(k), self.hi.get(k));
            a.is_finite() && b.is_finite() && a < b
        });
        if !ok {
            return Err(WallError::Box);
        }
        Ok(())
    }
}
