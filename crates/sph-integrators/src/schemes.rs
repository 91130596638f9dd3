//! The three time-update schemes.

use crate::projection::{Equation, det_f_stats, first_non_finite, prepare, project};
use crate::report::{Phase, PhaseTimes};
use crate::simulation::{Buffers, Engine, engine_context};
use crate::{
    EnergyBudget, HyperviscousRegion, ShiftScale, ShiftVelocity, Shifting, Simulation, StepError,
    StepReport, ViscousOperator, Walls,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sph_core::Dim;
use sph_core::{ParticleSet, VectorOps};
use sph_operators::{
    hyperviscous_acceleration, morris_error_coefficient, shifting_gradients, viscous_acceleration,
    viscous_correction,
};
use std::time::Instant;

/// One time-update scheme.
pub trait Integrator<D: Dim>: Send {
    /// Name for reports (`euler`, `predictor_corrector`, `dg`).
    fn name(&self) -> &'static str;
    /// Advances `sim` by `dt`. On error the particles are left as they were at the start of the
    /// step, so nothing already computed is lost.
    fn step(&mut self, sim: &mut Simulation<D>, dt: f64) -> Result<StepReport, StepError>;
}

/// First-order Euler ISPH (Lee et al. 2008; paper Eqs. 3–4): PPE at `xⁿ`,
/// `xⁿ⁺¹ = xⁿ + Δt uⁿ⁺¹`.
#[derive(Clone, Copy, Debug, Default)]
pub struct EulerIsph;

/// Cummins & Rudman (1999) predictor–corrector ISPH (paper Algorithm 2): `x' = xⁿ + Δt uⁿ`, PPE
/// at `x'`, `uⁿ⁺¹ = u* − Δt ∇p/ρ`, `xⁿ⁺¹ = xⁿ + Δt (uⁿ + uⁿ⁺¹)/2`.
#[derive(Clone, Copy, Debug, Default)]
pub struct PredictorCorrectorIsph;

/// Deformation-gradient ISPH (paper Algorithm 1): `A = I + ∇(Δt u*)` at `xⁿ`,
/// `(Δt²/ρ) cof(A):∇∇p = det A − 1`, `uⁿ⁺¹ = u* − Δt ∇p/ρ`, `xⁿ⁺¹ = xⁿ + Δt uⁿ⁺¹`.
#[derive(Clone, Copy, Debug, Default)]
pub struct DgIsph;

/// Scheme as named in a scene file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SchemeKind {
    /// [`EulerIsph`].
    Euler,
    /// [`PredictorCorrectorIsph`].
    PredictorCorrector,
    /// [`DgIsph`].
    Dg,
}

impl SchemeKind {
    /// All schemes.
    pub const ALL: [SchemeKind; 3] = [
        SchemeKind::Euler,
        SchemeKind::PredictorCorrector,
        SchemeKind::Dg,
    ];

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            SchemeKind::Euler => "euler",
            SchemeKind::PredictorCorrector => "predictor_corrector",
            SchemeKind::Dg => "dg",
        }
    }
}

/// A scheme chosen at run time.
#[derive(Clone, Copy, Debug)]
pub enum Scheme {
    /// See [`EulerIsph`].
    Euler(EulerIsph),
    /// See [`PredictorCorrectorIsph`].
    PredictorCorrector(PredictorCorrectorIsph),
    /// See [`DgIsph`].
    Dg(DgIsph),
}

impl Scheme {
    /// The scheme of the given kind.
    pub fn new(kind: SchemeKind) -> Self {
        match kind {
            SchemeKind::Euler => Scheme::Euler(EulerIsph),
            SchemeKind::PredictorCorrector => Scheme::PredictorCorrector(PredictorCorrectorIsph),
            SchemeKind::Dg => Scheme::Dg(DgIsph),
        }
    }
}

impl<D: Dim> Integrator<D> for Scheme {
    fn name(&self) -> &'static str {
        match self {
            Scheme::Euler(s) => Integrator::<D>::name(s),
            Scheme::PredictorCorrector(s) => Integrator::<D>::name(s),
            Scheme::Dg(s) => Integrator::<D>::name(s),
        }
    }
    fn step(&mut self, sim: &mut Simulation<D>, dt: f64) -> Result<StepReport, StepError> {
        match self {
            Scheme::Euler(s) => s.step(sim, dt),
            Scheme::PredictorCorrector(s) => s.step(sim, dt),
            Scheme::Dg(s) => s.step(sim, dt),
        }
    }
}

/// The explicit part of Algorithms 1 and 2, `u* = uⁿ + Δt (ν∇²uⁿ + f_b)`, on the neighbour
/// lists of `e` (built at `xⁿ`), plus the hyperviscous term where declared
/// ([`Hyperviscosity`](crate::Hyperviscosity)). Only the declared effects run: without any
/// `u* = uⁿ` and no loop is entered. Wall particles keep their prescribed velocity; the viscous
/// term reads the no-slip wall velocity `2u_w − ũ_w` (see [`WallModel`](crate::WallModel)).
fn intermediate_velocity<D: Dim>(
    e: &Engine<D>,
    b: &mut Buffers<D>,
    p: &ParticleSet<D>,
    walls: Option<&Walls<D>>,
    dt: f64,
    phases: &mut PhaseTimes,
) {
    b.u_star.copy_from_slice(&p.velocities);
    let fx = e.config.effects;
    if fx.viscosity.is_none() && fx.gravity.is_none() && fx.hyperviscosity.is_none() {
        return;
    }
    let nf = e.fluid;
    // Only the fluid's accelerations are computed and read.
    b.acc[..nf].fill(D::Vector::ZERO);
    if let Some(v) = fx.viscosity {
        let clock = Instant::now();
        let ctx = engine_context!(e, &p.positions);
        b.u_visc.copy_from_slice(&p.velocities);
        if let Some(w) = walls {
            w.no_slip_velocity(&ctx, &p.velocities, &mut b.u_visc[nf..]);
        }
        // The fluid's rows only: the walls keep their prescribed velocity.
        match v.operator {
            ViscousOperator::Morris => {
                let acc = &mut b.acc[..nf];
                viscous_acceleration(&ctx, &p.masses, &p.densities, v.nu, &b.u_visc, acc);
            }
            ViscousOperator::Corrected => {
                // The fluid's uncorrected values (the walls' slots are never read: a particle
                // with a wall neighbour is not corrected).
                let a = &mut b.visc_acc[..nf];
                a.fill(D::Vector::ZERO);
                viscous_acceleration(&ctx, &p.masses, &p.densities, v.nu, &b.u_visc, a);
                let c = morris_error_coefficient::<D, _>(&e.kernel);
                let (nl, surface) = (&e.neighbors, &e.dirichlet);
                let interior = |i: usize| {
                    nl.row(i)
                        .iter()
                        .all(|&j| (j as usize) < nf && !surface[j as usize])
                };
                let acc = &mut b.acc[..nf];
                viscous_correction(&ctx, &p.masses, &p.densities, c, &b.visc_acc, interior, acc);
            }
        }
        phases.add(Phase::Viscosity, clock);
    }
    // After the viscous term, whose corrected form overwrites `acc`.
    if let Some(hv) = fx.hyperviscosity {
        let clock = Instant::now();
        let ctx = engine_context!(e, &p.positions);
        let nu4 = hv.speed * e.config.h.powi(3);
        let (grad, lap) = (&mut b.hv_grad, &mut b.hv_lap);
        let pressures = &p.pressures;
        let active = |i: usize| match hv.region {
            HyperviscousRegion::Everywhere => true,
            HyperviscousRegion::PositivePressure => pressures[i] > 0.0,
        };
        let acc = &mut b.acc[..nf];
        hyperviscous_acceleration(&ctx, nu4, &p.velocities, active, grad, lap, acc);
        phases.add(Phase::Hyperviscosity, clock);
    }
    if let Some(g) = fx.gravity {
        let clock = Instant::now();
        let g = D::Vector::from_fn(|k| g[k]);
        for a in &mut b.acc[..nf] {
            *a += g;
        }
        phases.add(Phase::Gravity, clock);
    }
    for (u, a) in b.u_star[..nf].iter_mut().zip(&b.acc[..nf]) {
        *u += *a * dt;
    }
}

/// Largest particle shift as a fraction of the initial spacing.
const MAX_SHIFT: f64 = 0.2;

/// Particle shifting (see [`Shifting`](crate::Shifting)) at the projection's configuration:
/// adds `δr_i = −A h U_i Δt ∇C_i`, `U_i` the scale's speed ([`ShiftScale`](crate::ShiftScale):
/// `|uⁿ⁺¹_i|`, the largest, or the largest where `pⁿ⁺¹_i < 0`) (only its part tangential to `∇C_i` on a free surface;
/// capped at 0.2 Δp, and at half the particle's distance to a wall, see
/// [`Walls::limit_shift`](crate::Walls::limit_shift)) to the fluid displacements and corrects
/// `uⁿ⁺¹_i += ∇uⁿ⁺¹_i δr_i`.
struct ShiftBuffers<'a, D: Dim> {
    grad_c: &'a mut [D::Vector],
    grad_u: &'a mut [D::Matrix],
    u_new: &'a mut [D::Vector],
    u_old: &'a mut [D::Vector],
    disp: &'a mut [D::Vector],
    /// The projection's new pressure (the tension scale reads its sign).
    pressure: &'a [f64],
}

fn shift<D: Dim>(e: &Engine<D>, b: ShiftBuffers<'_, D>, x: &[D::Vector], sh: Shifting, dt: f64) {
    let l = e.config.renormalise.then_some(&e.corrections[..]);
    let nf = e.fluid;
    // The concentration term evaluates W per pair: choose the kernel once, outside the loop.
    // The fluid's rows only: walls do not shift.
    let (grad_c, grad_u) = (&mut b.grad_c[..nf], &mut b.grad_u[..nf]);
    sph_kernels::with_kernel!(&e.kernel, k => {
        let ctx = engine_context!(e, x, k);
        shifting_gradients(&ctx, sh.spacing, b.u_new, l, grad_c, grad_u);
    });
    if sh.velocity_correction == ShiftVelocity::Limited {
        b.u_old[..nf].copy_from_slice(&b.u_new[..nf]);
    }
    // The velocities before any correction (the limiter's range).
    let u_old = &*b.u_old;
    let pressure = b.pressure;
    let h = e.config.h;
    let cap = MAX_SHIFT * sh.spacing;
    let free = e.config.free_surface.is_some();
    let (grad_c, grad_u) = (&*grad_c, &*grad_u);
    // δ⁺ scaling: the largest fluid speed (a maximum: the same in any order).
    let u_max = match sh.scale {
        ShiftScale::Local => 0.0,
        ShiftScale::Max | ShiftScale::Tension => b.u_new[..nf]
            .par_iter()
            .with_min_len(4096)
            .map(|u| u.length_squared())
            .reduce(|| 0.0, f64::max)
            .sqrt(),
    };
    // Each particle on its own: in parallel, and the same bits for any number of threads.
    b.disp[..nf]
        .par_iter_mut()
        .zip(b.u_new[..nf].par_iter_mut())
        .enumerate()
        .with_min_len(1024)
        .for_each(|(i, (disp, u_new))| {
            let g = grad_c[i];
            let speed = match sh.scale {
                ShiftScale::Local => u_new.length(),
                ShiftScale::Max => u_max,
                ShiftScale::Tension if pressure[i] < 0.0 => u_max,
                ShiftScale::Tension => u_new.length(),
            };
            let dr = g * (-sh.coefficient * h * speed * dt);
            // On a free surface only the part tangential to it is kept (Lind et al. 2012,
            // Sec. 3.3): the normal part of −∇C points out of the fluid and would spread the
            // surface. Particles below the surface keep the whole shift, which keeps them from
            // running into the surface layer (whose p = 0 cannot push them back).
            let dr = constrain_shift(e, x, i, dr, free && e.dirichlet[i], cap);
            *disp += dr;
            match sh.velocity_correction {
                ShiftVelocity::Taylor => *u_new += grad_u[i] * dr,
                ShiftVelocity::None => {}
                ShiftVelocity::Limited => {
                    let (mut lo, mut hi) = (u_old[i], u_old[i]);
                    for &j in e.neighbors.row(i) {
                        if (j as usize) < nf {
                            lo = lo.min(u_old[j as usize]);
                            hi = hi.max(u_old[j as usize]);
                        }
                    }
                    let v = *u_new + grad_u[i] * dr;
                    *u_new = D::Vector::from_fn(|k| v.get(k).clamp(lo.get(k), hi.get(k)));
                }
            }
        });
}

/// The constraints every shift of particle `i` obeys (shifting and the start's packing): with
/// `tangential`, only the part tangential to the surface, whose normal is that of the truncated
/// support, `ν = Σ V_j ∇W_ij` (without the anti-clumping term, so the shift keeps its
/// tangential part); on a free-surface particle in contact with a wall, nothing into it
/// ([`Walls::hold_contact_shift`](crate::Walls::hold_contact_shift)); then at most `cap` long,
/// and at most half the distance to a wall ([`Walls::limit_shift`](crate::Walls::limit_shift)).
pub(crate) fn constrain_shift<D: Dim>(
    e: &Engine<D>,
    x: &[D::Vector],
    i: usize,
    mut dr: D::Vector,
    tangential: bool,
    cap: f64,
) -> D::Vector {
    // The walls' contact rule acts on free-surface particles only.
    let contact = e.walls.as_ref().filter(|_| e.dirichlet[i]);
    if tangential || contact.is_some() {
        let ctx = engine_context!(e, x);
        if tangential {
            let mut nu = D::Vector::ZERO;
            ctx.for_each_pair(i, |p| nu += p.grad_w * ctx.volumes[p.j]);
            let n2 = nu.length_squared();
            if n2 > 0.0 {
                dr -= nu * (dr.dot(nu) / n2);
            }
        }
        if let Some(w) = contact {
            dr = w.hold_contact_shift(&ctx, i, dr);
        }
    }
    let len = dr.length();
    if len > cap {
        dr *= cap / len;
    }
    if let Some(w) = &e.walls {
        dr = w.limit_shift(x[i], dr);
    }
    dr
}

/// Where the projection is evaluated and how positions are advanced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PositionRule {
    /// Projection at `xⁿ`; `xⁿ⁺¹ = xⁿ + Δt uⁿ⁺¹` (Euler, DG).
    Current,
    /// Projection at `x' = xⁿ + Δt uⁿ`; `xⁿ⁺¹ = xⁿ + Δt (uⁿ + uⁿ⁺¹)/2` (predictor–corrector).
    Predicted,
}

/// One projection step: `u*` → (predictor) → neighbours, flags, corrections → pressure solve →
/// `uⁿ⁺¹` → displacement → (shifting) → blow-up checks → (diagnostics) → commit. Nothing is
/// written to the particles before every fallible part has succeeded.
fn projection_step<D: Dim>(
    sim: &mut Simulation<D>,
    dt: f64,
    equation: Equation,
    rule: PositionRule,
) -> Result<StepReport, StepError> {
    let t0 = Instant::now();
    let mut phases = PhaseTimes::default();
    let step = sim.step;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(StepError::InvalidTimeStep { step, dt });
    }
    sim.ensure_buffers();
    if sim.renumbers_next() {
        // Counted with the neighbour search, whose order it restores.
        let clock = Instant::now();
        sim.reorder_by_cell();
        phases.add(Phase::Neighbors, clock);
    }
    // Mirror ghosts follow the fluid (and its numbering): placed before the lists are built.
    sim.refresh_walls()?;
    projection_passes(sim, dt, equation, rule, t0, phases)
        .map_err(|e| e.with_particle_ids(&sim.order.ids))
}

/// [`projection_step`] after the renumbering: the step's passes on the particles as they are
/// numbered now (errors name slots; the caller maps them to initial indices).
fn projection_passes<D: Dim>(
    sim: &mut Simulation<D>,
    dt: f64,
    equation: Equation,
    rule: PositionRule,
    t0: Instant,
    mut phases: PhaseTimes,
) -> Result<StepReport, StepError> {
    let (step, t) = (sim.step, sim.t);
    let fx = sim.engine.config.effects;
    // The explicit terms that read the neighbours at xⁿ.
    let viscous = fx.viscosity.is_some() || fx.hyperviscosity.is_some();
    let det_f_wanted = sim.engine.config.diagnostics.det_f;
    let p = &sim.particles;
    // The explicit forces read the lists at xⁿ (Algorithms 1–2: ν∇²uⁿ).
    let mut correction_fallbacks = 0;
    sim.engine.saved.valid = false;
    if viscous {
        correction_fallbacks = prepare_current(&mut sim.engine, p, step, t, &mut phases)?;
    }
    intermediate_velocity(
        &sim.engine,
        &mut sim.buf,
        p,
        sim.engine.walls.as_ref(),
        dt,
        &mut phases,
    );
    let nf = sim.engine.fluid;
    let ke_n = kinetic_energy(&p.masses[..nf], &p.velocities[..nf]);
    let ke_star = kinetic_energy(&p.masses[..nf], &sim.buf.u_star[..nf]);
    if viscous && rule == PositionRule::Predicted && det_f_wanted {
        // Keep the xⁿ lists for the det F diagnostics below.
        sim.engine.swap_saved();
        sim.engine.saved.valid = true;
    }
    let x_eval = match rule {
        PositionRule::Current => &p.positions,
        PositionRule::Predicted => {
            let periodic = sim.engine.periodic;
            for ((xp, x), u) in sim
                .buf
                .x_pred
                .iter_mut()
                .zip(&p.positions)
                .zip(&p.velocities)
                .take(nf)
            {
                let y = *x + *u * dt;
                *xp = periodic.map_or(y, |per| per.wrap(y));
            }
            // Walls do not move (a lid's velocity is tangential and prescribed); mirror
            // ghosts are placed at the predicted fluid positions.
            sim.buf.x_pred[nf..].copy_from_slice(&p.positions[nf..]);
            if let Some(w) = &mut sim.engine.walls {
                w.place_ghosts(&mut sim.buf.x_pred)
                    .map_err(|(needed, slots)| StepError::GhostCapacity {
                        step,
                        t,
                        needed,
                        slots,
                    })?;
            }
            // A predictor that already moves a particle past the limit is a blow-up (its
            // lists and matrix would be built on positions that no longer form a fluid).
            let (far, max2) =
                first_largest(p.velocities[..nf].par_iter().map(|u| u.length_squared()));
            let value = max2.sqrt() * dt / sim.engine.config.h;
            if value.is_nan() || value > sim.engine.config.limits.max_displacement {
                return Err(blow_up(&sim.engine, p, far, value, dt, step, t));
            }
            &sim.buf.x_pred
        }
    };
    if !(viscous && rule == PositionRule::Current) {
        correction_fallbacks = prepare(
            &mut sim.engine,
            x_eval,
            &p.masses,
            &p.densities,
            step,
            t,
            &mut phases,
        )?;
    }
    // Work on a copy of the pressure so a failed solve leaves the particles untouched.
    sim.buf.p_work.copy_from_slice(&p.pressures);
    let projected = project(
        &mut sim.engine,
        x_eval,
        &p.densities,
        &sim.buf.u_star,
        &mut sim.buf.p_work,
        dt,
        equation,
        &mut sim.buf.u_new,
        step,
        t,
        &mut phases,
    )?;
    if let Some(particle) = first_non_finite(&sim.buf.u_new) {
        return Err(StepError::NonFinite {
            step,
            t,
            field: "velocity",
            particle,
        });
    }
    if let Some(particle) = sim.buf.p_work.iter().position(|v| !v.is_finite()) {
        return Err(StepError::NonFinite {
            step,
            t,
            field: "pressure",
            particle,
        });
    }
    let mut wall_contacts = hold_contacts(&sim.engine, x_eval, &mut sim.buf.u_new);
    let ke_proj = kinetic_energy(&p.masses[..nf], &sim.buf.u_new[..nf]);
    let half = 0.5 * dt;
    // The predictor–corrector's displacement also reads uⁿ, which shifting's velocity
    // correction may have left moving into a wall: the free-surface wall condition applies to it
    // too (a copy in shifting's buffer; the stored uⁿ is not changed). Without shifting uⁿ is
    // the last projection's, already held.
    let shifting = sim.engine.config.effects.shifting.is_some();
    let u_old: &[D::Vector] =
        if rule == PositionRule::Predicted && shifting && has_contacts(&sim.engine) {
            sim.buf.u_shift.copy_from_slice(&p.velocities);
            wall_contacts += hold_contacts(&sim.engine, x_eval, &mut sim.buf.u_shift);
            &sim.buf.u_shift
        } else {
            &p.velocities
        };
    for ((d, u), un) in sim.buf.disp.iter_mut().zip(u_old).zip(&sim.buf.u_new) {
        *d = match rule {
            PositionRule::Current => *un * dt,
            PositionRule::Predicted => (*u + *un) * half,
        };
    }
    sim.buf.disp[nf..].fill(D::Vector::ZERO);
    if projected.density_correction.is_some() {
        // The density correction's displacements (velocities untouched), under the shifts'
        // constraints: at most 0.2 Δx, at most half the distance to a wall.
        let clock = Instant::now();
        let e = &sim.engine;
        let cap = MAX_SHIFT * e.volumes[0].powf(1.0 / D::DIM as f64);
        sim.buf.disp[..nf]
            .par_iter_mut()
            .enumerate()
            .with_min_len(1024)
            .for_each(|(i, d)| *d += constrain_shift(e, x_eval, i, e.correction[i], false, cap));
        phases.add(Phase::Correction, clock);
    }
    if let Some(sh) = sim.engine.config.effects.shifting {
        let clock = Instant::now();
        let bufs = ShiftBuffers {
            grad_c: &mut sim.buf.grad_c,
            grad_u: &mut sim.buf.grad_u,
            u_new: &mut sim.buf.u_new,
            u_old: &mut sim.buf.u_shift,
            disp: &mut sim.buf.disp,
            pressure: &sim.buf.p_work,
        };
        shift(&sim.engine, bufs, x_eval, sh, dt);
        phases.add(Phase::Shifting, clock);
    }
    if let Some(w) = &sim.engine.walls {
        hold_departed(
            w,
            sim.engine.periodic,
            &p.positions[..nf],
            &mut sim.buf.disp[..nf],
            &mut sim.buf.u_new[..nf],
        );
    }
    let (max_displacement, deepest) =
        check_displacements(&sim.engine, p, &sim.buf.disp, dt, step, t)?;
    // The guard acts only on a particle whose end point lies in wall material (depth > 0); the
    // check has just found the deepest end point, so when it is 0 there is none to scan for.
    let wall_guarded = if deepest > 0.0 {
        guard_walls(&sim.engine, p, &mut sim.buf.disp, &mut sim.buf.u_new)
    } else {
        0
    };
    let energy = EnergyBudget {
        explicit: ke_star - ke_n,
        projection: ke_proj - ke_star,
        regularisation: kinetic_energy(&p.masses[..nf], &sim.buf.u_new[..nf]) - ke_proj,
    };
    let det_f = if det_f_wanted {
        let clock = Instant::now();
        if rule == PositionRule::Predicted {
            // The step's deformation is measured from xⁿ: take back the lists set aside there,
            // or rebuild them (keeping the free-surface flags of the projection either way).
            if sim.engine.saved.valid {
                sim.engine.swap_saved();
                sim.engine.saved.valid = false;
            } else {
                sim.buf.flags.copy_from_slice(&sim.engine.dirichlet);
                // The rebuild's passes count as diagnostics, not as the step's own.
                let mut rebuild = PhaseTimes::default();
                prepare_current(&mut sim.engine, p, step, t, &mut rebuild)?;
                sim.engine.dirichlet.copy_from_slice(&sim.buf.flags);
            }
        }
        let stats = det_f_stats(&sim.engine, &p.positions, &sim.buf.disp, &mut sim.buf.det_f);
        phases.add(Phase::Diagnostics, clock);
        Some(stats)
    } else {
        None
    };
    // Mirror ghosts at the end positions: fail before anything is written if there are too
    // few slots for them.
    if let Some((needed, slots)) = sim.engine.walls.as_ref().and_then(|w| {
        w.ghosts_needed(
            p.positions[..nf]
                .iter()
                .zip(&sim.buf.disp)
                .map(|(x, d)| *x + *d),
        )
    }) && needed > slots
    {
        return Err(StepError::GhostCapacity {
            step,
            t,
            needed,
            slots,
        });
    }
    commit(sim);
    sim.refresh_walls()?;
    // A particle in wall material after the step is one whose end point `x + δx` (the point
    // `commit` has just moved it to, the same sum) lies at a depth > 0, so none is when the
    // check's deepest end point is at depth 0 and the guard did not run: the count's pass over
    // every fluid particle is needed only otherwise.
    let wall_penetrations = if deepest > 0.0 {
        sim.wall_penetrations()
    } else {
        0
    };
    let report = StepReport {
        step,
        t: t + dt,
        dt,
        solve: projected.solve,
        max_div_u: projected.max_div_u,
        det_f,
        free_surface_particles: projected.free_surface,
        correction_fallbacks,
        hessian_fallbacks: projected.hessian_fallbacks,
        gauge_multiplier: projected.gauge_multiplier,
        wall_penetrations,
        max_displacement,
        wall_guarded,
        wall_contacts,
        energy,
        phases,
        seconds: t0.elapsed().as_secs_f64(),
    };
    sim.t += dt;
    sim.step += 1;
    Ok(report)
}

/// The blow-up error of a step in which fluid particle `particle` would move `value`
/// smoothing lengths.
fn blow_up<D: Dim>(
    e: &Engine<D>,
    p: &ParticleSet<D>,
    particle: usize,
    value: f64,
    dt: f64,
    step: usize,
    t: f64,
) -> StepError {
    let h = e.config.h;
    StepError::BlowUp {
        step,
        t,
        particle,
        value,
        limit: e.config.limits.max_displacement,
        viscous_number: e
            .config
            .effects
            .viscosity
            .map_or(0.0, |v| v.nu * dt / (h * h)),
        advective_number: p.velocities[..e.fluid]
            .par_iter()
            .map(|u| u.length_squared())
            .reduce(|| 0.0, f64::max)
            .sqrt()
            * dt
            / h,
        dt_bound: None,
    }
}

/// The blow-up checks of a step, before anything is committed: no fluid particle may move more
/// than [`Limits::max_displacement`](crate::Limits) smoothing lengths, nor end deeper in wall
/// material than the walls are thick. Returns the largest displacement in smoothing lengths and
/// the deepest end point's depth in wall material (0 without walls).
fn check_displacements<D: Dim>(
    e: &Engine<D>,
    p: &ParticleSet<D>,
    disp: &[D::Vector],
    dt: f64,
    step: usize,
    t: f64,
) -> Result<(f64, f64), StepError> {
    let nf = e.fluid;
    let h = e.config.h;
    let (far, max2) = first_largest(disp[..nf].par_iter().map(|d| d.length_squared()));
    let value = max2.sqrt() / h;
    let limit = e.config.limits.max_displacement;
    if value.is_nan() || value > limit {
        return Err(blow_up(e, p, far, value, dt, step, t));
    }
    let mut deepest_depth = 0.0;
    if let Some(w) = &e.walls {
        let deepest = first_largest(p.positions[..nf].par_iter().zip(&disp[..nf]).map(|(x, d)| {
            let y = *x + *d;
            let y = e.periodic.map_or(y, |per| per.wrap(y));
            // An end point beyond the wall layers was reached over an open rim (one step is
            // shorter than the layers are thick): the particle left the domain.
            w.material_depth(y)
        }));
        if deepest.1 > w.thickness {
            return Err(StepError::Escaped {
                step,
                t,
                particle: deepest.0,
                depth: deepest.1,
                thickness: w.thickness,
            });
        }
        deepest_depth = deepest.1;
    }
    Ok((value, deepest_depth))
}

/// Fluid particles that have left the domain over an open container's rim
/// ([`Walls::beyond`](crate::Walls::beyond): outside every container, past its wall layers)
/// are out of the flow: one already there stays where it is, at rest; one whose step ends
/// there ends it at rest. Spray thrown out of an open tank is thus neither taken for a particle
/// that passed through a wall nor left to fall for ever (its speed would set the automatic
/// step). The count is in every record (`left_domain`).
fn hold_departed<D: Dim>(
    w: &crate::Walls<D>,
    periodic: Option<sph_core::Periodic<D>>,
    x: &[D::Vector],
    disp: &mut [D::Vector],
    u_new: &mut [D::Vector],
) {
    disp.par_iter_mut()
        .zip(u_new.par_iter_mut())
        .zip(x.par_iter())
        .with_min_len(1024)
        .for_each(|((d, u), &x)| {
            if w.beyond(x) {
                *d = D::Vector::ZERO;
                *u = D::Vector::ZERO;
            } else {
                let y = x + *d;
                if w.beyond(periodic.map_or(y, |per| per.wrap(y))) {
                    *u = D::Vector::ZERO;
                }
            }
        });
}

/// The first index holding the largest value above 0 and that value, `(0, 0.0)` if none is
/// (NaN never counts): a sequential scan's answer, found in parallel — each piece keeps its
/// first largest, and of two pieces the right one wins only if strictly larger.
pub(crate) fn first_largest(values: impl IndexedParallelIterator<Item = f64>) -> (usize, f64) {
    values
        .enumerate()
        .with_min_len(1024)
        .fold(
            || (0, 0.0_f64),
            |(k, m), (i, v)| if v > m { (i, v) } else { (k, m) },
        )
        .reduce(|| (0, 0.0), |a, b| if b.1 > a.1 { b } else { a })
}

/// The free-surface particles' wall condition ([`Walls::hold_contacts`](crate::Walls::hold_contacts))
/// at the configuration `x` the step's lists belong to; the number of particles it changed.
fn hold_contacts<D: Dim>(e: &Engine<D>, x: &[D::Vector], u: &mut [D::Vector]) -> usize {
    match &e.walls {
        Some(w) if has_contacts(e) => w.hold_contacts(&engine_context!(e, x), &e.dirichlet, u),
        _ => 0,
    }
}

/// Whether the free-surface particles' wall condition can act: walls and a free surface.
fn has_contacts<D: Dim>(e: &Engine<D>) -> bool {
    e.walls.is_some() && e.dirichlet.iter().any(|d| *d)
}

/// The walls' last line of defence: a fluid particle in the fluid region whose displacement
/// would carry it across a wall (the projection did not stop it, e.g. a thin film sliding fast
/// along a floor) has the components of its displacement into the wall cut to half its distance
/// to that wall ([`Walls::limit_shift`](crate::Walls::limit_shift)), and its velocity
/// components along them scaled alike. Returns how many particles it caught (each step's
/// report and record carry the count, so the guard never acts unseen).
fn guard_walls<D: Dim>(
    e: &Engine<D>,
    p: &ParticleSet<D>,
    disp: &mut [D::Vector],
    u_new: &mut [D::Vector],
) -> usize {
    let Some(w) = &e.walls else { return 0 };
    let nf = e.fluid;
    // Each particle on its own (a count is exact in any order): in parallel.
    disp[..nf]
        .par_iter_mut()
        .zip(u_new[..nf].par_iter_mut())
        .zip(p.positions[..nf].par_iter())
        .with_min_len(1024)
        .map(|((disp, u_new), &x)| {
            let y = x + *disp;
            let y = e.periodic.map_or(y, |per| per.wrap(y));
            if w.material_depth(y) > 0.0 && w.depth(x) == 0.0 {
                let d = *disp;
                let cut = w.limit_shift(x, d);
                *u_new = D::Vector::from_fn(|k| {
                    let (a, b) = (d.get(k), cut.get(k));
                    if a != 0.0 && a != b {
                        u_new.get(k) * (b / a)
                    } else {
                        u_new.get(k)
                    }
                });
                *disp = cut;
                1
            } else {
                0
            }
        })
        .sum()
}

/// `½ Σ m |u|²`, summed in order (the same bits for any number of threads).
fn kinetic_energy<V: VectorOps>(masses: &[f64], u: &[V]) -> f64 {
    0.5 * masses
        .iter()
        .zip(u)
        .map(|(m, u)| m * u.length_squared())
        .sum::<f64>()
}

/// [`prepare`] at the particles' current positions `xⁿ`.
fn prepare_current<D: Dim>(
    e: &mut Engine<D>,
    p: &ParticleSet<D>,
    step: usize,
    t: f64,
    phases: &mut PhaseTimes,
) -> Result<usize, StepError> {
    prepare(e, &p.positions, &p.masses, &p.densities, step, t, phases)
}

/// Writes the step's results to the particles: `x += disp` (wrapped into the periodic box),
/// `u = u_new`, `p = p_work`.
fn commit<D: Dim>(sim: &mut Simulation<D>) {
    let p = &mut sim.particles;
    let periodic = sim.engine.periodic;
    p.pressures.copy_from_slice(&sim.buf.p_work);
    for ((x, u), (d, un)) in p
        .positions
        .iter_mut()
        .zip(p.velocities.iter_mut())
        .zip(sim.buf.disp.iter().zip(&sim.buf.u_new))
    {
        *x += *d;
        if let Some(per) = &periodic {
            *x = per.wrap(*x);
        }
        *u = *un;
    }
}

impl<D: Dim> Integrator<D> for EulerIsph {
    fn name(&self) -> &'static str {
        "euler"
    }
    fn step(&mut self, sim: &mut Simulation<D>, dt: f64) -> Result<StepReport, StepError> {
        projection_step(sim, dt, Equation::Ppe, PositionRule::Current)
    }
}

impl<D: Dim> Integrator<D> for DgIsph {
    fn name(&self) -> &'static str {
        "dg"
    }
    fn step(&mut self, sim: &mut Simulation<D>, dt: f64) -> Result<StepReport, StepError> {
        projection_step(sim, dt, Equation::Dg, PositionRule::Current)
    }
}

impl<D: Dim> Integrator<D> for PredictorCorrectorIsph {
    fn name(&self) -> &'static str {
        "predictor_corrector"
    }
    fn step(&mut self, sim: &mut Simulation<D>, dt: f64) -> Result<StepReport, StepError> {
        projection_step(sim, dt, Equation::Ppe, PositionRule::Predicted)
    }
}
