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
    /// Mirror ghosts of a closed box (Szewc, Pozorski & Minier 2012, Int. J. Numer. Meth. Engng
    /// 92, 343, the walls of the paper's cavity): before every neighbour search each fluid
    /// particle closer than the kernel support to a face of the box is mirrored across it, and
    /// near a corner across both faces (and in 3D all three): `x_g = S (x_s − x_w) + x_w` per
    /// face. See [`Ghosts`] for the values a ghost carries.
    MirrorGhosts,
}

/// The mirror ghosts of [`WallModel::MirrorGhosts`]: the wall particles `first..n` are slots,
/// each either a ghost of a fluid particle (its *source*) or parked out of every fluid
/// particle's reach. A ghost carries its source's values mirrored, as Szewc et al.'s mirror
/// particles do; which mirror each operator reads is ours (the Re 100 cavity at 20², RMS of its
/// centrelines off Ghia's: 0.023–0.031 with the no-slip mirror in the divergence, 0.009–0.023
/// with the free-slip one, 0.006–0.007 with the dummy walls):
///
/// * in the viscous term, its source's velocity reflected no-slip across the face it was
///   mirrored across, `u_g = 2 u_face − u_s` (across two faces, a corner: `u_s`);
/// * in the divergence and DG's `A`, the free-slip reflection: the component normal to the face
///   reversed about the face's, `u_{g,n} = 2 u_{face,n} − u_{s,n}`, the tangential ones kept,
///   so that a divergence-free field stays divergence-free across the wall (the no-slip
///   reflection of the viscous term would add `2 ∂u_n/∂n` to it);
/// * its source's pressure, `p_g = p_s + ρ_s g·(x_g − x_s)` (homogeneous Neumann `∂p/∂n = 0`
///   at rest, the hydrostatic slope under gravity): the ghost is no unknown of the pressure
///   equation — a fluid row's coefficient on `p_g` is added to its coefficient on `p_s`
///   ([`fold_ghost_columns`](sph_pressure::fold_ghost_columns)), so the discrete Laplacian a
///   fluid particle sees is the one whose gradient corrects its velocity.
///
/// The number of slots is fixed when the walls are built (the particle set keeps its size): a
/// step that needs more ghosts than slots fails with
/// [`StepError::GhostCapacity`](crate::StepError::GhostCapacity).
#[derive(Clone, Debug, PartialEq)]
pub struct Ghosts<D: Dim> {
    /// Lower corner of the box (the fluid region; its faces are the walls).
    pub lo: D::Vector,
    /// Upper corner of the box.
    pub hi: D::Vector,
    /// Velocity of each face: `face_velocity[2k]` of the face `x_k = lo_k`, `[2k + 1]` of
    /// `x_k = hi_k` (`2 D` entries).
    pub face_velocity: Vec<D::Vector>,
    /// A fluid particle closer than this to a face gets a ghost across it (the kernel support).
    pub reach: f64,
    /// Where each slot waits while it is not a ghost: beyond the reach of every fluid particle
    /// and of each other.
    pub park: Vec<D::Vector>,
    /// Source fluid particle of each slot ([`Ghosts::PARKED`] for a parked slot).
    pub source: Vec<u32>,
    /// Faces each slot is mirrored across: bit `2k` the face `x_k = lo_k`, bit `2k + 1` the face
    /// `x_k = hi_k`.
    pub faces: Vec<u8>,
}

impl<D: Dim> Ghosts<D> {
    /// [`Ghosts::source`] of a parked slot.
    pub const PARKED: u32 = u32::MAX;

    /// The ghosts' box `[lo, hi]` with its faces' velocities, reach and `slots` slots, parked
    /// on a lattice of spacing `1.5 reach` beside the box's `+x` face, `3 reach` beyond it.
    pub fn new(
        lo: D::Vector,
        hi: D::Vector,
        face_velocity: Vec<D::Vector>,
        reach: f64,
        slots: usize,
    ) -> Self {
        let spacing = 1.5 * reach;
        // Columns (2D) or planes (3D) across the box's other axes.
        let across: Vec<usize> = (1..D::DIM)
            .map(|a| ((hi.get(a) - lo.get(a)) / spacing).floor() as usize + 1)
            .collect();
        let per_column: usize = across.iter().product();
        let park = (0..slots)
            .map(|k| {
                let (column, mut rest) = (k / per_column, k % per_column);
                D::Vector::from_fn(|a| {
                    if a == 0 {
                        hi.get(0) + 3.0 * reach + column as f64 * spacing
                    } else {
                        let i = rest % across[a - 1];
                        rest /= across[a - 1];
                        lo.get(a) + i as f64 * spacing
                    }
                })
            })
            .collect();
        Self {
            lo,
            hi,
            face_velocity,
            reach,
            park,
            source: vec![Self::PARKED; slots],
            faces: vec![0; slots],
        }
    }

    /// The faces within reach of `x`: bit `2k` when `x_k − lo_k < reach`, bit `2k + 1` when
    /// `hi_k − x_k < reach` (the box is wider than twice the reach, checked by the builder).
    fn near(&self, x: D::Vector) -> u8 {
        let mut bits = 0u8;
        for a in 0..D::DIM {
            if x.get(a) - self.lo.get(a) < self.reach {
                bits |= 1 << (2 * a);
            } else if self.hi.get(a) - x.get(a) < self.reach {
                bits |= 1 << (2 * a + 1);
            }
        }
        bits
    }

    /// How many ghosts the fluid positions `x` need: `2^m − 1` for a particle near `m` faces.
    pub fn needed(&self, x: impl Iterator<Item = D::Vector>) -> usize {
        x.map(|x| (1usize << self.near(x).count_ones()) - 1).sum()
    }

    /// `x` mirrored across the faces `faces`.
    fn mirror_point(&self, mut x: D::Vector, faces: u8) -> D::Vector {
        for a in 0..D::DIM {
            if faces & (1 << (2 * a)) != 0 {
                x.set(a, 2.0 * self.lo.get(a) - x.get(a));
            }
            if faces & (1 << (2 * a + 1)) != 0 {
                x.set(a, 2.0 * self.hi.get(a) - x.get(a));
            }
        }
        x
    }

    /// The source's velocity `u` reflected no-slip across the faces `faces`: `2 u_f − u` across
    /// one face `f`; across several, the average over the orders of reflecting face by face
    /// (`u ← 2 u_f − u` per face), which is `2 ū − u` for an odd number of faces (`ū` their
    /// mean velocity) and `u` for two. One order alone would make a corner ghost's velocity
    /// depend on which face is taken first where a moving lid meets a wall at rest.
    fn no_slip_velocity(&self, u: D::Vector, faces: u8) -> D::Vector {
        let m = faces.count_ones();
        if m.is_multiple_of(2) {
            return u;
        }
        let mut mean = D::Vector::ZERO;
        for f in 0..2 * D::DIM {
            if faces & (1 << f) != 0 {
                mean += self.face_velocity[f];
            }
        }
        mean * (2.0 / m as f64) - u
    }

    /// The source's velocity `u` reflected free-slip across the faces `faces`: relative to each
    /// face's velocity (tangential: a wall slides along itself) the normal component changes
    /// sign, `u_k ← 2 u_{f,k} − u_k` along each mirrored axis `k`, the tangential ones are kept.
    /// Divergence-free fields stay divergence-free across the face (the no-slip reflection adds
    /// `2 ∂u_n/∂n` there).
    fn free_slip_velocity(&self, mut u: D::Vector, faces: u8) -> D::Vector {
        for f in 0..2 * D::DIM {
            if faces & (1 << f) != 0 {
                let a = f / 2;
                u.set(a, 2.0 * self.face_velocity[f].get(a) - u.get(a));
            }
        }
        u
    }

    /// Mirror of slot `k`: `−1` along the axes it was mirrored across.
    fn mirror_axes(&self, k: usize) -> D::Vector {
        let f = self.faces[k];
        D::Vector::from_fn(|a| if f & (3 << (2 * a)) != 0 { -1.0 } else { 1.0 })
    }

    /// Direction into the wall of slot `k`: `−1` (lo face) or `+1` (hi face) along the axes it
    /// was mirrored across, 0 along the others.
    fn inward_axes(&self, k: usize) -> D::Vector {
        let f = self.faces[k];
        D::Vector::from_fn(|a| {
            if f & (1 << (2 * a)) != 0 {
                -1.0
            } else if f & (1 << (2 * a + 1)) != 0 {
                1.0
            } else {
                0.0
            }
        })
    }
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
    /// The mirror ghosts ([`WallModel::MirrorGhosts`]; `None` for dummy particles).
    pub ghosts: Option<Ghosts<D>>,
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
    /// The model is [`WallModel::MirrorGhosts`] without [`Walls::ghosts`], or ghosts are given
    /// for another model.
    #[error("walls: mirror ghosts are given exactly when the model is MirrorGhosts")]
    Model,
    /// The fluid needs more mirror ghosts than there are wall slots.
    #[error("walls: the fluid needs {needed} mirror ghosts, the walls have {slots} slots")]
    GhostCapacity {
        /// Ghosts needed.
        needed: usize,
        /// Slots.
        slots: usize,
    },
    /// A geometry box is empty or not finite, or the thickness is not positive.
    #[error("walls: a wall box is empty or not finite, or the wall thickness is not positive")]
    Box,
}

/// A free-surface particle is in contact with a wall particle closer than this many spacings
/// along the wall's normal ([`Walls::hold_contacts`]): just under one, so a particle at a
/// lattice's distance (exactly one spacing from the first wall layer) is not in contact.
const CONTACT_REACH: f64 = 0.999;

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
    /// Mirror ghosts carry their source's velocity reflected no-slip ([`Ghosts`]).
    pub fn no_slip_velocity<K: Kernel<D>>(
        &self,
        ctx: &SphContext<'_, D, K>,
        u: &[D::Vector],
        out: &mut [D::Vector],
    ) {
        if self.ghosts.is_some() {
            self.ghost_velocities(u, out);
            return;
        }
        self.map_shepard(ctx, u, out, |k, ut| self.velocity[k] * 2.0 - ut);
    }

    /// Each ghost slot's velocity from the fluid velocities `u` (indexed as the particles):
    /// its source's reflected no-slip ([`Ghosts`]), 0 for a parked slot. Nothing is written
    /// without ghosts.
    pub fn ghost_velocities(&self, u: &[D::Vector], out: &mut [D::Vector]) {
        self.map_ghosts(u, out, Ghosts::no_slip_velocity);
    }

    /// As [`Walls::ghost_velocities`] with the free-slip reflection (normal component odd about
    /// the face's, tangential even): the velocity the divergence and DG's `A` read.
    pub(crate) fn ghost_divergence_velocities(&self, u: &[D::Vector], out: &mut [D::Vector]) {
        self.map_ghosts(u, out, Ghosts::free_slip_velocity);
    }

    /// `out[k] = mirror(ghosts, u[source], faces)` for each ghost slot `k`, 0 for a parked one.
    fn map_ghosts(
        &self,
        u: &[D::Vector],
        out: &mut [D::Vector],
        mirror: impl Fn(&Ghosts<D>, D::Vector, u8) -> D::Vector,
    ) {
        let Some(g) = &self.ghosts else { return };
        for (k, o) in out.iter_mut().enumerate() {
            let s = g.source[k];
            *o = if s == Ghosts::<D>::PARKED {
                D::Vector::ZERO
            } else {
                mirror(g, u[s as usize], g.faces[k])
            };
        }
    }

    /// Each ghost slot's value of a scalar field known on the fluid (`values[..first]`):
    /// `values[g] = values[s] + ρ_s grad·(x_g − x_s)` for the ghost `g` of source `s` (`grad`
    /// the prescribed `∇p/ρ`: gravity for the pressure, 0 for a potential with zero Neumann
    /// data), 0 for a parked slot. Nothing is written without ghosts.
    pub fn ghost_values(
        &self,
        x: &[D::Vector],
        densities: &[f64],
        grad: D::Vector,
        values: &mut [f64],
    ) {
        let Some(g) = &self.ghosts else { return };
        let nf = self.first;
        for k in 0..g.source.len() {
            let s = g.source[k];
            values[nf + k] = if s == Ghosts::<D>::PARKED {
                0.0
            } else {
                let s = s as usize;
                values[s] + densities[s] * grad.dot(x[nf + k] - x[s])
            };
        }
    }

    /// Each ghost slot's source, for the pressure equation's folding
    /// ([`sph_pressure::fold_ghost_columns`]); `None` without ghosts.
    pub(crate) fn ghost_sources(&self) -> Option<&[u32]> {
        self.ghosts.as_ref().map(|g| &g.source[..])
    }

    /// How many ghost slots the fluid positions `x` need, and how many there are; `None`
    /// without ghosts.
    pub fn ghosts_needed(&self, x: impl Iterator<Item = D::Vector>) -> Option<(usize, usize)> {
        self.ghosts.as_ref().map(|g| (g.needed(x), g.source.len()))
    }

    /// Places the mirror ghosts of the fluid positions `x[..first]` in the wall slots
    /// `x[first..]` (fluid particles in order, each one's faces in the order of their bits),
    /// parks the slots left over, and sets each slot's mirror and inward direction. Returns
    /// `Err((needed, slots))` — leaving `x` as it was — when there are too few slots. Nothing
    /// is done without ghosts.
    pub fn place_ghosts(&mut self, x: &mut [D::Vector]) -> Result<(), (usize, usize)> {
        let nf = self.first;
        let Some(g) = &mut self.ghosts else {
            return Ok(());
        };
        let needed = g.needed(x[..nf].iter().copied());
        let slots = g.source.len();
        if needed > slots {
            return Err((needed, slots));
        }
        let mut k = 0;
        for i in 0..nf {
            let near = g.near(x[i]);
            // Every non-empty subset of the near faces.
            let mut sub = near;
            while sub != 0 {
                x[nf + k] = g.mirror_point(x[i], sub);
                g.source[k] = i as u32;
                g.faces[k] = sub;
                k += 1;
                sub = (sub - 1) & near;
            }
        }
        for j in k..slots {
            x[nf + j] = g.park[j];
            g.source[j] = Ghosts::<D>::PARKED;
            g.faces[j] = 0;
        }
        for k in 0..slots {
            self.mirror[k] = g.mirror_axes(k);
            self.inward[k] = g.inward_axes(k);
        }
        Ok(())
    }

    /// Brings the wall slots of `particles` up to date with its fluid particles (mirror ghosts:
    /// positions, velocities, pressures with the prescribed `∇p/ρ` `grad`); nothing for dummy
    /// particles. Fails as [`Walls::place_ghosts`] does, leaving the particles unchanged.
    pub fn refresh(
        &mut self,
        particles: &mut sph_core::ParticleSet<D>,
        grad: D::Vector,
    ) -> Result<(), (usize, usize)> {
        if self.ghosts.is_none() {
            return Ok(());
        }
        self.place_ghosts(&mut particles.positions)?;
        let nf = self.first;
        let (fluid, walls) = particles.velocities.split_at_mut(nf);
        self.ghost_velocities(fluid, walls);
        self.ghost_values(
            &particles.positions,
            &particles.densities,
            grad,
            &mut particles.pressures,
        );
        Ok(())
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
        if self.ghosts.is_some() {
            // Mirror ghosts: the source's velocity reflected free-slip (the no-penetration
            // condition); the pressure equation reads no Neumann data (the ghosts' columns are
            // folded onto their sources').
            self.ghost_divergence_velocities(u, u_out);
            if let Some(g) = grad_out {
                g.fill(D::Vector::ZERO);
            }
            return;
        }
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

    /// The wall condition of the free-surface particles (`free[i]`), which the projection
    /// cannot reach: their pressure is fixed at 0, so no wall pressure solved with them stops
    /// them, and the wall particles' own pressures cover only the wall's half of their kernel
    /// support. A free-surface particle `i` in contact with a wall — closer than one spacing
    /// `Δx_i = V_i^{1/d}` along a wall particle's normal axis `a` to that particle, i.e. nearer
    /// the face than a lattice's Δx/2 — loses the velocity component into that wall:
    ///
    /// ```text
    /// (u_i − u_w)_a s_a > 0  and  |(x_i − x_w)_a| < Δx_i   ⇒   u_{i,a} = u_{w,a}
    /// ```
    ///
    /// (`s = inward[w]`, the direction from the fluid into the wall). The discrete form of
    /// `(u − u_wall)·n ≤ 0` at the wall (`n` pointing into it) for the particles without a
    /// pressure row; a velocity away from the wall is left alone. Returns how many particles it changed (each step's report
    /// and record carry the count).
    pub fn hold_contacts<K: Kernel<D>>(
        &self,
        ctx: &SphContext<'_, D, K>,
        free: &[bool],
        u: &mut [D::Vector],
    ) -> usize {
        let first = self.first;
        u[..first]
            .par_iter_mut()
            .zip(&free[..first])
            .enumerate()
            .with_min_len(1024)
            .map(|(i, (u, &free))| {
                if !free {
                    return 0;
                }
                let before = *u;
                *u = self.hold_contact(ctx, i, *u, |j| self.velocity[j]);
                usize::from(*u != before)
            })
            .sum()
    }

    /// The free-surface particles' wall condition for a shift (a displacement no velocity
    /// carries: shifting, the density correction, the start's packing) of fluid particle `i`:
    /// as [`Walls::hold_contacts`] for velocities, each component of `dr` that moves the
    /// particle into a wall layer closer than the contact reach is dropped (walls do not move
    /// during a shift). Without it a free-surface particle in contact, whose velocity into the
    /// wall is held at the wall's, could still be shifted onto the wall's face, half its distance
    /// at a time.
    pub fn hold_contact_shift<K: Kernel<D>>(
        &self,
        ctx: &SphContext<'_, D, K>,
        i: usize,
        dr: D::Vector,
    ) -> D::Vector {
        self.hold_contact(ctx, i, dr, |_| D::Vector::ZERO)
    }

    /// The contact rule of fluid particle `i` for a vector `v` (its velocity, or a shift): each
    /// component moving it, relative to `wall(k)` of wall particle `k` (numbered from the first
    /// wall particle), into a wall layer within the contact reach along that particle's normal
    /// axis becomes that wall value's.
    fn hold_contact<K: Kernel<D>>(
        &self,
        ctx: &SphContext<'_, D, K>,
        i: usize,
        mut v: D::Vector,
        wall: impl Fn(usize) -> D::Vector,
    ) -> D::Vector {
        let first = self.first;
        let reach = CONTACT_REACH * ctx.volumes[i].powf(1.0 / D::DIM as f64);
        let xi = ctx.positions[i];
        for j in ctx.neighbors_of(i) {
            if j < first {
                continue;
            }
            let (n, vw) = (self.inward[j - first], wall(j - first));
            let r = ctx.pair(xi, j);
            v = D::Vector::from_fn(|a| {
                let (s, va) = (n.get(a), v.get(a));
                if s != 0.0 && r.get(a).abs() < reach && (va - vw.get(a)) * s > 0.0 {
                    vw.get(a)
                } else {
                    va
                }
            });
        }
        v
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
        if (self.model == WallModel::MirrorGhosts) != self.ghosts.is_some() {
            return Err(WallError::Model);
        }
        if self.first + self.velocity.len() != particles
            || self.mirror.len() != self.velocity.len()
            || self.inward.len() != self.velocity.len()
            || self.ghosts.as_ref().is_some_and(|g| {
                g.source.len() != self.velocity.len()
                    || g.park.len() != self.velocity.len()
                    || g.faces.len() != self.velocity.len()
                    || g.face_velocity.len() != 2 * D::DIM
            })
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
