//! Solid walls.

use crate::WallGeometry;
use rayon::prelude::*;
use sph_core::{Dim, VectorOps};
use sph_kernels::Kernel;
use sph_operators::SphContext;
use thiserror::Error;

/// How walls are represented. Wall particles are stored after the fluid particles in the same
/// [`ParticleSet`](sph_core::ParticleSet), take part in every neighbour sum, have pressure
/// unknowns in the pressure equation, and never move. How the no-penetration condition reaches
/// the projection is the separate [`WallCondition`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum WallModel {
    /// Fixed dummy particles (Adami, Hu & Adams 2012, J. Comput. Phys. 231, 7057): a few layers
    /// of particles on the initial lattice behind each wall.
    ///
    /// * viscosity (no slip): `2 u_w − ũ_w`, with `ũ_w` the Shepard average of the fluid
    ///   velocities around the wall particle (Adami Eq. 22–23);
    /// * divergence, `A = I + ∇(Δt u*)` and pressure: see [`WallCondition`].
    ///
    /// Because the wall pressures are unknowns of the same system, the discrete Laplacian (or DG
    /// Hessian) a fluid particle sees is the same operator whose gradient corrects its velocity.
    #[default]
    DummyParticles,
}

/// How the wall's no-penetration condition `u·n = u_wall·n` enters the projection: through the
/// velocity the divergence (and DG's `A`) reads at the wall particles, and through the right-hand
/// side of the wall particles' pressure rows (the extrapolation of Adami et al. 2012, Eq. 27,
/// `p_w = Σ_f (p_f + ρ_f g_w·(x_w − x_f)) W_wf / Σ_f W_wf`, with `g_w` the prescribed `∇p/ρ`).
///
/// One projection of a uniform stream `u* = U e_x` in a closed box must stop it: the exact
/// answer is `uⁿ⁺¹ = 0` with `p = ρ U x / Δt`. [`Continuation`](Self::Continuation) leaves
/// 2 % of `U` in the first particle layer at the side walls at every resolution,
/// [`Reflection`](Self::Reflection) 52 % (test `closed_walls_stop_a_uniform_stream`). A
/// divergence-free field tangential to the walls (a Taylor–Green cell) must pass unchanged:
/// Reflection changes it by 0.12 % RMS at 20² (dx = 0.05), Continuation by 1.3 %, converging as
/// `Δx^1.5` (test `tangential_divergence_free_flow_passes_the_walls`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WallCondition {
    /// The fluid velocity is continued into the wall unchanged (the Shepard average
    /// `ũ*_w` of the fluid `u*` around the wall particle), and the pressure carries the
    /// condition as Neumann data from the projection's momentum equation
    /// `uⁿ⁺¹ = u* − Δt ∇p/ρ` with `uⁿ⁺¹·n = u_wall·n`:
    ///
    /// ```text
    /// g_w = P_n (ũ*_w − u_wall)/Δt + (I − P_n) g,     P_n = (I − S_w)/2
    /// ```
    ///
    /// (`S_w` the wall particle's [`mirror`](Walls::mirror), so `P_n` keeps the components
    /// normal to its wall(s)). At rest under gravity `u* = gΔt` and this is Adami's `g_w = g`.
    /// Both fields stay smooth across the wall, so the SPH gradient of the wall pressures is the
    /// slope the condition prescribes. The default.
    #[default]
    Continuation,
    /// The velocity is reflected about the wall's, its normal part odd:
    /// `u_w = u_wall + S_w (ũ*_w − u_wall)`, and the pressure extrapolated evenly (`g_w = g`).
    /// In the continuum the pair imposes `∂p/∂n = ρ (u* − u_wall)·n / Δt` through the jump of
    /// the reflected normal velocity; the Shepard-extrapolated pressure has no kink to match it,
    /// and the SPH gradient straddling the wall blurs it, so part of a normal velocity survives
    /// each projection.
    /// The older condition, kept for comparison; a scene selects it with
    /// `wall_condition = "reflection"`.
    Reflection,
}

/// Walls of a simulation: particles `first..n` of the particle set, their prescribed velocities
/// and mirrors, and the geometry the fluid must stay in (penetration measure, shift limit).
#[derive(Clone, Debug, PartialEq)]
pub struct Walls<D: Dim> {
    /// The wall model.
    pub model: WallModel,
    /// How the no-penetration condition enters the projection.
    pub condition: WallCondition,
    /// Index of the first wall particle; the fluid particles are `0..first`.
    pub first: usize,
    /// Prescribed velocity of each wall particle (`n − first` entries).
    pub velocity: Vec<D::Vector>,
    /// Reflection of each wall particle's wall: `−1` along the axes normal to the wall(s) it
    /// sits behind, `+1` along the others (a corner block flips two axes).
    pub mirror: Vec<D::Vector>,
    /// Direction from the fluid into the wall along each axis the mirror flips (`+1` or `−1`;
    /// `0` along the other axes), one per wall particle.
    pub inward: Vec<D::Vector>,
    /// The fluid may leave the wall (flows with a free surface): the wall condition stops only
    /// a velocity into the wall and leaves one away from it alone, so a wall never pulls the
    /// fluid with a negative pressure. Without it (a closed box) `u·n = u_wall·n` is imposed
    /// both ways, as incompressibility demands when no free surface can open a gap.
    pub separation: bool,
    /// Where the walls are (containers and solid obstacles).
    pub geometry: WallGeometry<D>,
    /// Thickness of the wall layers. A fluid particle deeper in wall material than this has
    /// passed through the wall: the step fails (see [`StepError::Escaped`](crate::StepError)).
    pub thickness: f64,
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
    /// A geometry box is empty or not finite, or the thickness is not positive.
    #[error("walls: a wall box is empty or not finite, or the wall thickness is not positive")]
    Box,
}

impl<D: Dim> Walls<D> {
    /// How deep `x` lies in wall material (0 in the fluid region), see
    /// [`WallGeometry::depth`].
    pub fn depth(&self, x: D::Vector) -> f64 {
        self.geometry.depth(x)
    }

    /// Whether `x` has left the domain: outside every container, beyond its wall layers
    /// ([`WallGeometry::beyond_walls`]). A fluid particle gets there only over the rim of an
    /// open face (spray thrown out of an open tank); the schemes then hold it where it left,
    /// at rest, out of the flow (see [`Walls::left_domain`]).
    pub fn beyond(&self, x: D::Vector) -> bool {
        self.geometry.beyond_walls(x, self.thickness)
    }

    /// How deep `x` lies in wall material, 0 for a point that has left the domain
    /// ([`Walls::beyond`]): what the penetration count, the intrusion depth, the blow-up test
    /// and the guard read.
    pub fn material_depth(&self, x: D::Vector) -> f64 {
        if self.beyond(x) { 0.0 } else { self.depth(x) }
    }

    /// Number of fluid particles that have left the domain over an open rim ([`Walls::beyond`]).
    pub fn left_domain(&self, positions: &[D::Vector]) -> usize {
        positions[..self.first]
            .par_iter()
            .with_min_len(4096)
            .filter(|x| self.beyond(**x))
            .count()
    }

    /// Number of fluid particles in wall material (each one has crossed a wall); particles
    /// that left the domain over an open rim are not in wall material.
    pub fn penetrations(&self, positions: &[D::Vector]) -> usize {
        // A count and (below) a maximum: exact in any order, so in parallel.
        positions[..self.first]
            .par_iter()
            .with_min_len(4096)
            .filter(|x| self.material_depth(**x) > 0.0)
            .count()
    }

    /// How deep the deepest fluid particle lies in wall material (0 when none does). Tells a
    /// particle in the half-spacing gap between the wall line and the first wall layer
    /// (depth < Δp/2) from one that has passed the wall particles. Particles that left the
    /// domain do not count.
    pub fn max_intrusion(&self, positions: &[D::Vector]) -> f64 {
        positions[..self.first]
            .par_iter()
            .with_min_len(4096)
            .map(|x| self.material_depth(*x))
            .reduce(|| 0.0, f64::max)
    }

    /// A shift `dr` of the fluid particle at `x`, shortened so that it can bring the particle
    /// closer to a wall but never across it ([`WallGeometry::limit_shift`]: a wall-ward
    /// component takes at most half the distance to the wall). Shifting is a regularisation of
    /// the particle distribution, not a flow: near a wall its anti-clumping term, pushed by a
    /// fluid neighbour that came too close, could otherwise move a particle across the wall line
    /// (seen at the lid of a 100² cavity: a particle 0.09 Δp below the lid, moving away from it,
    /// was shifted 0.2 Δp into it).
    pub fn limit_shift(&self, x: D::Vector, dr: D::Vector) -> D::Vector {
        self.geometry.limit_shift(x, dr)
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

    /// What the projection reads at the wall particles (see [`WallCondition`]): the velocity the
    /// divergence and DG's `A` see (`u_out`) and, when `grad_out` is given, the Neumann data
    /// `g_w = ∇p/ρ` of the pressure rows. `u` is the fluid velocity being projected (`u*`), or
    /// `uⁿ⁺¹` for the divergence diagnostic; `gravity` and `dt` enter `g_w` only.
    pub(crate) fn boundary_data<K: Kernel<D>>(
        &self,
        ctx: &SphContext<'_, D, K>,
        u: &[D::Vector],
        gravity: D::Vector,
        dt: f64,
        u_out: &mut [D::Vector],
        grad_out: Option<&mut [D::Vector]>,
    ) {
        let condition = self.condition;
        let normal = |k: usize, v: D::Vector| {
            let s = self.mirror[k];
            D::Vector::from_fn(|a| 0.5 * (1.0 - s.get(a)) * v.get(a))
        };
        self.map_shepard(ctx, u, u_out, |k, ut| match condition {
            WallCondition::Continuation => ut,
            WallCondition::Reflection => {
                let w = self.velocity[k];
                let s = self.mirror[k];
                w + D::Vector::from_fn(|a| s.get(a) * (ut.get(a) - w.get(a)))
            }
        });
        if let Some(g) = grad_out {
            g.par_iter_mut()
                .enumerate()
                .with_min_len(256)
                .for_each(|(k, g)| {
                    *g = match condition {
                        WallCondition::Continuation => {
                            // u_out[k] = ũ*_k; its normal part minus the wall's, per Δt, plus
                            // the tangential part of gravity. With separation, only the part
                            // into the wall.
                            let mut du = normal(k, u_out[k] - self.velocity[k]);
                            if self.separation {
                                let n = self.inward[k];
                                du = D::Vector::from_fn(|a| {
                                    let (d, s) = (du.get(a), n.get(a));
                                    if d * s > 0.0 { d } else { 0.0 }
                                });
                            }
                            du * (1.0 / dt) + gravity - normal(k, gravity)
                        }
                        WallCondition::Reflection => gravity,
                    };
                });
        }
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
                        let wij = ctx.kernel.w(ctx.pair(xw, j).length());
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
        if self.first + self.velocity.len() != particles
            || self.mirror.len() != self.velocity.len()
            || self.inward.len() != self.velocity.len()
        {
            return Err(WallError::Count {
                first: self.first,
                walls: self.velocity.len(),
                particles,
            });
        }
        if !(self.geometry.is_valid() && self.thickness.is_finite() && self.thickness > 0.0) {
            return Err(WallError::Box);
        }
        Ok(())
    }
}
