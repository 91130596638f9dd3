//! The projection shared by all schemes.
//!
//! Order: neighbours at `x_eval` → volumes `V = m/ρ` → renormalisation `L` → free-surface flags
//! from `∇·r` → source (`∇·u*`, or `A = I + Δt∇u*` and `det A − 1`) → assemble → solve
//! (warm-started from the previous pressure) → `uⁿ⁺¹ = u* − Δt ∇p/ρ` → `max |∇·uⁿ⁺¹|`.

use crate::DensityRelaxationForm;
use crate::report::{Phase, PhaseTimes};
use crate::simulation::{Engine, engine_context};
use crate::{StepError, report::DetFStats};
use rayon::prelude::*;
use sph_core::{Dim, MatrixOps, VectorOps};
use sph_kernels::Kernel;
use sph_neighbors::NeighborSearch;
use sph_operators::{
    CutLattice, SphContext, correction_matrices, deformation_gradient, divergence,
    free_surface_indicator, free_surface_scan, grad_factors, grad_factors_and_values,
    grad_factors_from_squared_distances, gradient, invariants, kernel_sum_excess_near_surface,
    surface_depths, velocity_gradient,
};
use sph_pressure::{
    CsrSystem, LinearSolver, SolveInfo, add_level_term, assemble_dg, assemble_ppe,
    assemble_surface_rows, assemble_wall_rows, complete_cut_rows, fold_ghost_columns,
};
use std::time::Instant;

/// Which pressure equation to solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Equation {
    /// Pressure Poisson equation (Euler, predictor–corrector).
    Ppe,
    /// Deformation-gradient equation (DG-ISPH).
    Dg,
}

/// What a projection reports.
pub(crate) struct Projected {
    pub(crate) solve: SolveInfo,
    /// The density correction's solve, when the scene asks for one.
    pub(crate) density_correction: Option<SolveInfo>,
    pub(crate) max_div_u: Option<f64>,
    pub(crate) free_surface: usize,
    pub(crate) hessian_fallbacks: usize,
    pub(crate) gauge_multiplier: f64,
}

/// Smallest |det B| accepted for a renormalisation matrix before falling back to `L = I`
/// (bulk value ≈ 1; a flat free surface ≈ 0.5).
const MIN_CORRECTION_DET: f64 = 1e-3;

/// Largest amplification of a gradient by a renormalisation matrix (its largest entry) before
/// falling back to `L = I`: a flat free surface has about 2, a spray particle with a few
/// distant neighbours far more, and its corrected pressure gradient would fling it away.
const MAX_CORRECTION_GAIN: f64 = 5.0;

/// Builds the neighbour lists, volumes, corrections and free-surface flags at `x`.
pub(crate) fn prepare<D: Dim>(
    e: &mut Engine<D>,
    x: &[D::Vector],
    masses: &[f64],
    densities: &[f64],
    step: usize,
    t: f64,
    phases: &mut PhaseTimes,
) -> Result<usize, StepError> {
    let clock = Instant::now();
    e.search
        .build(x, e.kernel.support_radius())
        .map_err(|source| StepError::Neighbors { step, t, source })?;
    // The cell grid hands over the squared distance of every pair it keeps (the kernel's
    // factors are then a stream over them); other searches, and periodic domains, measure the
    // pairs again.
    let measured = e
        .search
        .query_with_squared_distances(x, &mut e.neighbors, &mut e.grad_factors);
    let shifting = e.config.effects.shifting.is_some();
    sph_kernels::with_kernel!(&e.kernel, k => {
        if measured {
            let values = shifting.then_some(&mut e.kernel_values);
            grad_factors_from_squared_distances(k, &mut e.grad_factors, values);
        } else {
            let ctx = SphContext::new(x, &e.volumes, &e.neighbors, k).with_periodic(e.periodic);
            if shifting {
                grad_factors_and_values(&ctx, &mut e.grad_factors, &mut e.kernel_values);
            } else {
                grad_factors(&ctx, &mut e.grad_factors);
            }
        }
    });
    if !shifting {
        e.kernel_values.clear();
    }
    phases.add(Phase::Neighbors, clock);
    let clock = Instant::now();
    for ((v, m), rho) in e.volumes.iter_mut().zip(masses).zip(densities) {
        *v = m / rho;
    }
    let ctx = engine_context!(e, x);
    let robin_rows = e
        .config
        .free_surface
        .is_some_and(|f| f.zero_pressure_depth > 0.0);
    let fallbacks = if e.config.renormalise || robin_rows {
        correction_matrices(
            &ctx,
            MIN_CORRECTION_DET,
            MAX_CORRECTION_GAIN,
            &mut e.corrections,
        )
        .fallbacks
    } else {
        0
    };
    phases.add(Phase::Renormalisation, clock);
    // The ∇·r pass runs only when the scene declares a free surface. Wall particles never get
    // Dirichlet rows: their pressures are extrapolated (the outer wall layers have a low ∇·r).
    match e.config.free_surface {
        Some(fs) => {
            let clock = Instant::now();
            free_surface_indicator(&ctx, &mut e.div_r);
            if fs.scan {
                let l = e.config.renormalise.then_some(&e.corrections[..]);
                free_surface_scan(&ctx, l, &mut e.dirichlet);
                for (d, r) in e.dirichlet.iter_mut().zip(&e.div_r) {
                    *d = *d || *r < fs.div_r_threshold;
                }
            } else {
                for (d, r) in e.dirichlet.iter_mut().zip(&e.div_r) {
                    *d = *r < fs.div_r_threshold;
                }
            }
            e.dirichlet[e.fluid..].fill(false);
            phases.add(Phase::FreeSurface, clock);
        }
        None => {
            e.dirichlet.fill(false);
            if e.config.normalised_gradient {
                let clock = Instant::now();
                free_surface_indicator(&ctx, &mut e.div_r);
                phases.add(Phase::FreeSurface, clock);
            }
        }
    }
    Ok(fallbacks)
}

/// Solves for the pressure at configuration `x` (prepared by [`prepare`]) and writes
/// `u_new = u* − Δt ∇p/ρ`. `pressures` holds the warm start on entry and the solution on exit.
pub(crate) fn project<D: Dim>(
    e: &mut Engine<D>,
    x: &[D::Vector],
    densities: &[f64],
    u_star: &[D::Vector],
    pressures: &mut [f64],
    dt: f64,
    equation: Equation,
    u_new: &mut [D::Vector],
    step: usize,
    t: f64,
    phases: &mut PhaseTimes,
) -> Result<Projected, StepError> {
    let ctx = engine_context!(e, x);
    let l = e.config.renormalise.then_some(&e.corrections[..]);
    let consistent = l.filter(|_| e.config.consistent_laplacian);
    let mut hessian_fallbacks = 0;
    let nf = e.fluid;
    let g = e.config.effects.gravity.unwrap_or([0.0; 3]);
    let gravity = D::Vector::from_fn(|k| g[k]);
    // The divergence (and A) read the walls' velocity, the wall rows their Neumann data, see
    // `WallCondition`.
    let u_star: &[D::Vector] = match &e.walls {
        Some(w) => {
            let clock = Instant::now();
            e.u_div.copy_from_slice(u_star);
            w.boundary_data(
                &ctx,
                u_star,
                gravity,
                dt,
                &mut e.u_div[nf..],
                Some(&mut e.wall_grad),
            );
            phases.add(Phase::WallData, clock);
            &e.u_div
        }
        None => u_star,
    };
    // Robin surface rows: the surface pressures stay unknowns, the bulk rows keep their columns.
    let robin = e
        .config
        .free_surface
        .map_or(0.0, |f| f.zero_pressure_depth)
        .max(0.0);
    let flags: &[bool] = if robin > 0.0 {
        &e.no_dirichlet
    } else {
        &e.dirichlet
    };
    let (velocity_form, position_form) = match e.config.density_relaxation_form {
        DensityRelaxationForm::Velocity => (e.config.density_relaxation, 0.0),
        DensityRelaxationForm::Position => (0.0, e.config.density_relaxation),
    };
    let clock = Instant::now();
    match equation {
        Equation::Ppe => {
            divergence(&ctx, u_star, l, &mut e.source[..nf]);
            // Velocity form: target divergence α e_i / Δt.
            relax_density(
                &ctx,
                velocity_form / dt,
                &e.dirichlet,
                &mut e.surface_band,
                &mut e.excess,
                &mut e.source[..nf],
            );
            phases.add(Phase::Source, clock);
            let clock = Instant::now();
            // Masses from volumes and densities: m_j = ρ_j V_j.
            for ((s, v), rho) in e.scalar.iter_mut().zip(&e.volumes).zip(densities) {
                *s = v * rho;
            }
            assemble_ppe(
                &ctx,
                &e.scalar,
                densities,
                &e.source,
                dt,
                flags,
                consistent,
                nf,
                &mut e.matrix,
                &mut e.rhs,
            )
            .map_err(|source| StepError::Assembly { step, t, source })?;
            phases.add(Phase::Assembly, clock);
        }
        Equation::Dg => {
            // A = I + Δt ∇u*,  det A − 1 = Δt I1 + Δt² I2 + Δt³ I3 (no cancellation).
            velocity_gradient(&ctx, u_star, l, &mut e.a[..nf]);
            for (a, s) in e.a[..nf].iter_mut().zip(&mut e.source[..nf]) {
                let inv = invariants::<D>(a);
                *s = dt * (inv.i1 + dt * (inv.i2 + dt * inv.i3));
                *a = D::Matrix::IDENTITY + *a * dt;
            }
            // Velocity form: target det A − 1 = α e_i.
            relax_density(
                &ctx,
                velocity_form,
                &e.dirichlet,
                &mut e.surface_band,
                &mut e.excess,
                &mut e.source[..nf],
            );
            phases.add(Phase::Source, clock);
            let clock = Instant::now();
            hessian_fallbacks = assemble_dg(
                &ctx,
                densities,
                &e.a,
                &e.source,
                dt,
                e.config.dg_hessian,
                flags,
                consistent,
                nf,
                &mut e.matrix,
                &mut e.rhs,
            )
            .map_err(|source| StepError::Assembly { step, t, source })?;
            phases.add(Phase::Assembly, clock);
        }
    }
    // No Dirichlet row: a closed domain, pressure defined up to a constant → mean-zero gauge.
    let closed = !e.dirichlet.iter().any(|d| *d);
    if e.config.free_surface.is_some_and(|f| f.complete_band) && !closed {
        let clock = Instant::now();
        mark_surface_band(&ctx, &e.dirichlet, &mut e.surface_band[..nf]);
        complete_band_rows(
            &ctx,
            &e.surface_band[..nf],
            &e.dirichlet,
            densities,
            (equation == Equation::Dg).then_some(&e.a[..nf]),
            &mut e.cut_lattice,
            &mut e.matrix,
        )
        .map_err(|source| StepError::Assembly { step, t, source })?;
        phases.add(Phase::Assembly, clock);
    }
    // The level term fixes the pressure's constant (`p c` is not invariant under it): only a free
    // surface may fix it, so a closed domain keeps its gauge and its lift, without the term.
    let level_term = e.config.level_consistent && !closed;
    let normalised = e.config.normalised_gradient;
    // The free surface's band (kept for the density correction below).
    let band_marked = (level_term || normalised) && !closed;
    if band_marked {
        mark_surface_band(&ctx, &e.dirichlet, &mut e.surface_band[..nf]);
    }
    if level_term {
        let clock = Instant::now();
        gradient(
            &ctx,
            &e.ones,
            sph_operators::GradientForm::Symmetric,
            None,
            &mut e.level[..nf],
        );
        if normalised {
            let band = band_marked.then_some(&e.surface_band[..nf]);
            normalise_gradient::<D>(&e.div_r, band, &mut e.level[..nf]);
        }
        // Not in the free surface's band: there `c_i` measures the support the surface cuts,
        // not disorder, and `p_i c_i` is the push that gives the surface rows the pressure
        // gradient their `p = 0` leaves out (docs/physics.md).
        for (c, b) in e.level[..nf].iter_mut().zip(&e.surface_band[..nf]) {
            if *b {
                *c = D::Vector::ZERO;
            }
        }
        add_level_term(&ctx, &e.level, densities, flags, nf, &mut e.matrix)
            .map_err(|source| StepError::Assembly { step, t, source })?;
        phases.add(Phase::Assembly, clock);
    }
    if robin > 0.0 {
        let clock = Instant::now();
        let depth = &mut e.surface_depth[..nf];
        let measured = e.config.free_surface.is_some_and(|f| f.measured_depth);
        let table = if measured {
            cut_lattice(&ctx, &mut e.cut_lattice)
        } else {
            None
        };
        match table {
            Some(cut) => {
                // Where the surface is in tension its Taylor sign condition fails and the
                // rows keep half a spacing: measured only where the last pressure is positive.
                let (flags, last) = (&e.dirichlet, &*pressures);
                let measure = |i: usize| flags[i] && last[i] > 0.0;
                surface_depths(&ctx, cut, measure, nf, robin, depth)
            }
            None => depth.fill(robin),
        }
        phases.add(Phase::FreeSurface, clock);
    }
    if nf < ctx.len() || robin > 0.0 {
        let clock = Instant::now();
        let ghosts = e
            .walls
            .as_ref()
            .and_then(|w| w.ghost_sources())
            .map(|s| (s, gravity));
        boundary_rows(
            &ctx,
            nf,
            densities,
            &e.wall_grad,
            &e.dirichlet,
            &e.corrections,
            (robin > 0.0).then(|| &e.surface_depth[..nf]),
            ghosts,
            &mut e.matrix,
            &mut e.rhs,
        )
        .map_err(|source| StepError::Assembly { step, t, source })?;
        phases.add(Phase::Assembly, clock);
    }
    if robin <= 0.0 {
        for (p, d) in pressures.iter_mut().zip(&e.dirichlet) {
            if *d {
                *p = 0.0;
            }
        }
    }
    let system = CsrSystem {
        offsets: e.neighbors.offsets(),
        cols: e.neighbors.indices(),
        values: &e.matrix.values,
        rhs: &e.rhs,
        border: None,
    };
    if !e.config.warm_start {
        pressures.fill(0.0);
    }
    let clock = Instant::now();
    let solve = if closed {
        e.gauge
            .solve(&mut e.solver, &system, nf, pressures, &e.config.solve)
    } else {
        e.gauge.last_multiplier = 0.0;
        e.solver.solve(&system, pressures, &e.config.solve)
    }
    .map_err(|source| StepError::Solve { step, t, source })?;
    if closed && e.config.gradient != sph_operators::GradientForm::Difference {
        lift_to_non_negative(pressures, nf);
    }
    let total = clock.elapsed().as_secs_f64();
    phases.add_seconds(Phase::PrecondSetup, solve.setup_seconds);
    phases.add_seconds(Phase::Solve, total - solve.setup_seconds);
    let clock = Instant::now();
    // Mirror ghosts take their sources' pressures (their own rows solved for 0).
    if let Some(w) = &e.walls {
        w.ghost_values(x, densities, gravity, pressures);
    }
    gradient(&ctx, pressures, e.config.gradient, l, &mut e.grad_p[..nf]);
    if normalised {
        let band = band_marked.then_some(&e.surface_band[..nf]);
        normalise_gradient::<D>(&e.div_r, band, &mut e.grad_p[..nf]);
    }
    for (((un, us), g), rho) in u_new[..nf]
        .iter_mut()
        .zip(u_star)
        .zip(&e.grad_p[..nf])
        .zip(densities)
    {
        *un = *us - *g * (dt / rho);
    }
    phases.add(Phase::Correction, clock);
    let max_div_u = if e.config.diagnostics.div_u {
        let clock = Instant::now();
        if let Some(w) = &e.walls {
            w.boundary_data(&ctx, &u_new[..nf], gravity, dt, &mut e.u_div[nf..], None);
            u_new[nf..].copy_from_slice(&e.u_div[nf..]);
        }
        divergence(&ctx, u_new, l, &mut e.scalar);
        let max = e.scalar[..nf]
            .iter()
            .zip(&e.dirichlet)
            .filter(|(_, d)| !**d)
            .map(|(v, _)| v.abs())
            .fold(0.0, f64::max);
        phases.add(Phase::Diagnostics, clock);
        Some(max)
    } else {
        None
    };
    // Wall particles keep their prescribed velocity; mirror ghosts reflect their sources'.
    if let Some(w) = &e.walls {
        if w.ghosts.is_some() {
            let (fluid, walls) = u_new.split_at_mut(nf);
            w.ghost_velocities(fluid, walls);
        } else {
            u_new[nf..].copy_from_slice(&w.velocity);
        }
    }
    let density_correction = if position_form > 0.0 {
        Some(correct_density(
            e,
            x,
            densities,
            dt,
            equation,
            robin,
            level_term,
            band_marked,
            step,
            t,
            phases,
        )?)
    } else {
        None
    };
    Ok(Projected {
        solve,
        density_correction,
        max_div_u,
        free_surface: e.dirichlet.iter().filter(|d| **d).count(),
        gauge_multiplier: e.gauge.last_multiplier,
        hessian_fallbacks,
    })
}

/// Density relaxation, position form (`SimConfig::density_relaxation`, `α`, with
/// [`DensityRelaxationForm::Position`]): after the projection, a second
/// Poisson solve at the same configuration gives each fluid particle a displacement, not a
/// velocity, that moves its summation density back towards a perfect lattice's by the fraction
/// `α` of its error:
///
/// ```text
/// ∇·((1/ρ) ∇q)_i = −α e_i / Δt²,   q = 0 on the free surface, ∂q/∂n = 0 at walls,
/// δr_i = −Δt² (∇q)_i / ρ_i         (so ∇·δr_i = α e_i)
/// ```
///
/// with `e_i = ρ̂_i/ρ̂_lattice − 1` the kernel-sum excess
/// ([`kernel_sum_excess_near_surface`]): where a free-surface particle is in the support, against
/// the sum of a lattice cut by a flat face at the depth the particle's own truncation says (0
/// on the surface particles and where the cut is more than a flat face's). The matrix is the
/// PPE's (paper Eq. 3's operator; assembled here for DG-ISPH and with the level term, whose
/// projection's matrix is another; otherwise the projection's is reused), the solve starts
/// from zero (no
/// state carried between steps: a resumed run is the same bits). The displacements are left in
/// `e.correction` for the scheme to add to the step's; the velocities are untouched, so the
/// correction restores the volume the divergence-free projection lets drift (Shao & Lo's
/// density-invariance source with Asai et al. 2012's relaxation `α`, solved apart from the
/// divergence-free projection as in Hu & Adams 2007's two-step projection, and applied to
/// positions only) without adding momentum.
#[allow(clippy::too_many_arguments)]
fn correct_density<D: Dim>(
    e: &mut Engine<D>,
    x: &[D::Vector],
    densities: &[f64],
    dt: f64,
    equation: Equation,
    robin: f64,
    level_term: bool,
    band_marked: bool,
    step: usize,
    t: f64,
    phases: &mut PhaseTimes,
) -> Result<SolveInfo, StepError> {
    let ctx = engine_context!(e, x);
    let nf = e.fluid;
    let l = e.config.renormalise.then_some(&e.corrections[..]);
    let clock = Instant::now();
    // The projection may have marked the band of these flags already.
    if !band_marked {
        mark_surface_band(&ctx, &e.dirichlet, &mut e.surface_band[..nf]);
    }
    kernel_sum_excess_near_surface(
        &ctx,
        ctx.volumes[0],
        &e.dirichlet,
        &e.surface_band[..nf],
        &mut e.excess[..nf],
    );
    phases.add(Phase::Source, clock);
    let clock = Instant::now();
    let alpha = e.config.density_relaxation;
    let scale = alpha / (dt * dt);
    // The displacement is the difference gradient of `q` (below), whose divergence the
    // assembled Laplacian matches: the level term belongs to the symmetric gradient only.
    let reuse = equation == Equation::Ppe && !level_term;
    if reuse {
        // The projection's matrix is this equation's: only the right-hand side changes (wall
        // and surface rows get zero data).
        for (i, r) in e.rhs.iter_mut().enumerate() {
            *r = if i < nf && !e.dirichlet[i] {
                scale * e.excess[i]
            } else {
                0.0
            };
        }
    } else {
        let consistent = l.filter(|_| e.config.consistent_laplacian);
        let flags: &[bool] = if robin > 0.0 {
            &e.no_dirichlet
        } else {
            &e.dirichlet
        };
        for ((s, v), rho) in e.scalar.iter_mut().zip(&e.volumes).zip(densities) {
            *s = v * rho;
        }
        for (s, x) in e.source[..nf].iter_mut().zip(&e.excess[..nf]) {
            *s = -alpha * x / dt;
        }
        assemble_ppe(
            &ctx,
            &e.scalar,
            densities,
            &e.source,
            dt,
            flags,
            consistent,
            nf,
            &mut e.matrix,
            &mut e.rhs,
        )
        .map_err(|source| StepError::Assembly { step, t, source })?;
        if e.config.free_surface.is_some_and(|f| f.complete_band) {
            complete_band_rows(
                &ctx,
                &e.surface_band[..nf],
                &e.dirichlet,
                densities,
                None,
                &mut e.cut_lattice,
                &mut e.matrix,
            )
            .map_err(|source| StepError::Assembly { step, t, source })?;
        }
        // Zero Neumann data: the wall rows' right-hand side is 0.
        e.wall_grad.fill(D::Vector::ZERO);
        let ghosts = e
            .walls
            .as_ref()
            .and_then(|w| w.ghost_sources())
            .map(|s| (s, D::Vector::ZERO));
        boundary_rows(
            &ctx,
            nf,
            densities,
            &e.wall_grad,
            &e.dirichlet,
            &e.corrections,
            (robin > 0.0).then(|| &e.surface_depth[..nf]),
            ghosts,
            &mut e.matrix,
            &mut e.rhs,
        )
        .map_err(|source| StepError::Assembly { step, t, source })?;
    }
    phases.add(Phase::Assembly, clock);
    let system = CsrSystem {
        offsets: e.neighbors.offsets(),
        cols: e.neighbors.indices(),
        values: &e.matrix.values,
        rhs: &e.rhs,
        border: None,
    };
    e.potential.fill(0.0);
    // The PPE's solver keeps its hierarchy for its matrix when this one is the same.
    let solver = if reuse {
        &mut e.solver
    } else {
        &mut e.correction_solver
    };
    let clock = Instant::now();
    let solve = if e.dirichlet.iter().any(|d| *d) {
        solver.solve(&system, &mut e.potential, &e.config.solve)
    } else {
        let multiplier = e.gauge.last_multiplier;
        let r = e
            .gauge
            .solve(solver, &system, nf, &mut e.potential, &e.config.solve);
        // The step reports the projection's multiplier.
        e.gauge.last_multiplier = multiplier;
        r
    }
    .map_err(|source| StepError::Solve { step, t, source })?;
    let total = clock.elapsed().as_secs_f64();
    phases.add_seconds(Phase::PrecondSetup, solve.setup_seconds);
    phases.add_seconds(Phase::Solve, total - solve.setup_seconds);
    let clock = Instant::now();
    if let Some(w) = &e.walls {
        w.ghost_values(x, densities, D::Vector::ZERO, &mut e.potential);
    }
    // The difference form: `Σ (q_j − q_i) ∇W_ij V_j` vanishes for a constant potential, where
    // the symmetric form's `q_i Σ ∇W_ij V_j` pushes particles of a truncated support (jets,
    // surfaces) by a force no velocity balances; with it the 4a tank's run-up exploded.
    gradient(
        &ctx,
        &e.potential,
        sph_operators::GradientForm::Difference,
        l,
        &mut e.correction[..nf],
    );
    for (d, rho) in e.correction[..nf].iter_mut().zip(densities) {
        *d *= -dt * dt / rho;
    }
    phases.add(Phase::Correction, clock);
    Ok(solve)
}

/// The rows the fluid's equation does not write: the walls' (Neumann data `wall_grad`), when
/// there are wall particles (from `first_wall` on), and with Robin surface rows (`robin`: each
/// fluid particle's depth) the free-surface particles'. Mirror ghosts (`ghosts`: their sources and the prescribed
/// `∇p/ρ`) are folded onto their sources instead of getting wall rows.
#[allow(clippy::too_many_arguments)]
fn boundary_rows<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    first_wall: usize,
    densities: &[f64],
    wall_grad: &[D::Vector],
    dirichlet: &[bool],
    corrections: &[D::Matrix],
    robin: Option<&[f64]>,
    ghosts: Option<(&[u32], D::Vector)>,
    matrix: &mut sph_pressure::CsrMatrix,
    rhs: &mut [f64],
) -> Result<(), sph_pressure::PressureError> {
    if first_wall < ctx.len() {
        match ghosts {
            Some((sources, grad)) => {
                fold_ghost_columns(ctx, first_wall, sources, densities, grad, matrix, rhs)?
            }
            None => assemble_wall_rows(ctx, first_wall, densities, wall_grad, matrix, rhs)?,
        }
    }
    if let Some(depth) = robin {
        assemble_surface_rows(ctx, dirichlet, corrections, depth, first_wall, matrix, rhs)?;
    }
    Ok(())
}

/// Completes the pressure rows of the free surface's band (`band`, less the surface particles
/// `surface`) with the neighbours a lattice cut at their depth misses, read as `p = 0`
/// ([`sph_pressure::complete_cut_rows`]; `FreeSurface::complete_band`): the PPE's rows with
/// `M_i = I/ρ_i`, DG's (`a`: the matrices `A_i`) with `cof(A_i)/ρ_i`. `table` keeps the cut
/// lattice between calls, rebuilt when the particle volume changes (a support wider than the
/// table's 15 spacings: nothing is completed).
fn complete_band_rows<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    band: &[bool],
    surface: &[bool],
    densities: &[f64],
    a: Option<&[D::Matrix]>,
    table: &mut Option<(f64, CutLattice)>,
    matrix: &mut sph_pressure::CsrMatrix,
) -> Result<(), sph_pressure::PressureError> {
    let Some(cut) = cut_lattice(ctx, table) else {
        return Ok(());
    };
    let metric = |i: usize| match a {
        None => D::Matrix::IDENTITY * (1.0 / densities[i]),
        Some(a) => a[i].cofactor() * (1.0 / densities[i]),
    };
    complete_cut_rows(ctx, band, surface, cut, &metric, band.len(), matrix)
}

/// The cut-lattice table for `ctx`'s kernel and particle volume, kept in `table` between calls
/// and rebuilt when the volume changes; `None` when the support spans more than the table's 15
/// spacings.
fn cut_lattice<'t, D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    table: &'t mut Option<(f64, CutLattice)>,
) -> Option<&'t CutLattice> {
    let volume = ctx.volumes[0];
    if table.as_ref().is_none_or(|(v, _)| *v != volume) {
        *table = CutLattice::new::<D, K>(ctx.kernel, volume).map(|c| (volume, c));
    }
    table.as_ref().map(|(_, cut)| cut)
}

/// `band[i]` for the first `band.len()` particles: whether a free-surface particle (`dirichlet`)
/// is in particle `i`'s support, itself included — the free surface's band, where kernel sums
/// measure the support the surface cuts.
fn mark_surface_band<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    dirichlet: &[bool],
    band: &mut [bool],
) {
    band.par_iter_mut()
        .enumerate()
        .with_min_len(256)
        .for_each(|(i, b)| *b = ctx.neighbors_of(i).any(|j| dirichlet[j]));
}

/// Divides `grad[i]` by `∇·r_i / D` (`SimConfig::normalised_gradient`) for the particles
/// outside the free surface's band (`band`, when the domain has a free surface) whose `∇·r_i`
/// is at least half the lattice's (an isolated particle's gradient is left alone):
///
/// ```text
/// (∇p)_i ← D (∇p)_i / (∇·r)_i,   (∇·r)_i = −Σ_j V_j x_ij·∇W_ij  (= D β on a perfect lattice)
/// ```
fn normalise_gradient<D: Dim>(div_r: &[f64], band: Option<&[bool]>, grad: &mut [D::Vector]) {
    let dim = D::DIM as f64;
    grad.par_iter_mut()
        .enumerate()
        .with_min_len(1024)
        .for_each(|(i, g)| {
            let in_band = band.is_some_and(|b| b[i]);
            if !in_band && div_r[i] >= 0.5 * dim {
                *g *= dim / div_r[i];
            }
        });
}

/// Density relaxation, velocity form (`SimConfig::density_relaxation`, Asai et al. 2012):
/// subtracts `rate · e_i` from each fluid particle's source (`source.len()` particles), `e_i` its
/// kernel-sum excess over a perfect lattice of the first particle's volume (a scene's particles
/// share one spacing). With `rate = α/Δt` the projection's target is `∇·u_i = α e_i / Δt`, with
/// `rate = α` DG's is `det A_i − 1 = α e_i`: by continuity the summation density then moves
/// back towards the lattice's by the fraction `α` of its error per step. Particles with a
/// free-surface particle (`dirichlet`) in their support are measured against a lattice cut at
/// their depth ([`kernel_sum_excess_near_surface`]); the surface particles keep their source.
/// `rate = 0`: nothing is done.
fn relax_density<D: Dim, K: Kernel<D>>(
    ctx: &SphContext<'_, D, K>,
    rate: f64,
    dirichlet: &[bool],
    band: &mut [bool],
    excess: &mut [f64],
    source: &mut [f64],
) {
    let nf = source.len();
    if rate <= 0.0 || nf == 0 {
        return;
    }
    mark_surface_band(ctx, dirichlet, &mut band[..nf]);
    kernel_sum_excess_near_surface(ctx, ctx.volumes[0], dirichlet, band, &mut excess[..nf]);
    for (s, e) in source.iter_mut().zip(&excess[..nf]) {
        *s -= rate * e;
    }
}

/// det F statistics of the displacement `disp` from configuration `x` (neighbour lists,
/// volumes and corrections of `e` must belong to `x`), over non-free-surface particles.
pub(crate) fn det_f_stats<D: Dim>(
    e: &Engine<D>,
    x: &[D::Vector],
    disp: &[D::Vector],
    f: &mut [D::Matrix],
) -> DetFStats {
    let ctx = engine_context!(e, x);
    let l = e.config.renormalise.then_some(&e.corrections[..]);
    deformation_gradient(&ctx, disp, l, f);
    let (mut min, mut max, mut sum, mut count) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
    for (fi, d) in f[..e.fluid].iter().zip(&e.dirichlet) {
        if !*d {
            let det = fi.determinant();
            min = min.min(det);
            max = max.max(det);
            sum += det;
            count += 1;
        }
    }
    if count == 0 {
        return DetFStats {
            min: 1.0,
            mean: 1.0,
            max: 1.0,
        };
    }
    DetFStats {
        min,
        mean: sum / count as f64,
        max,
    }
}

/// First particle with a non-finite entry in `v`, if any.
pub(crate) fn first_non_finite<V: VectorOps>(v: &[V]) -> Option<usize> {
    v.iter().position(|x| !x.is_finite())
}

/// Adds one constant to every pressure (fluid and wall particles) so that the lowest fluid
/// pressure is 0. In a closed domain the pressure equation fixes `p` only up to a constant
/// (solved with a mean-zero gauge), and the projection's velocities do not depend on it — except
/// through the symmetric gradient `Σ_j V_j (p_i + p_j) ∇W_ij`, which differs from the
/// difference form by `2 p_i Σ_j V_j ∇W_ij`. That term pushes a particle away from its
/// neighbours where `p_i > 0` and pulls it towards them where `p_i < 0` (the tensile
/// instability): a sealed tank at rest under gravity, mean-zero gauge, has `p < 0` in its upper
/// half and blows up within 0.23 s; lifted, every scheme holds it (`docs/physics.md`, "The
/// pressure level of a closed domain").
fn lift_to_non_negative(pressures: &mut [f64], nf: usize) {
    let lowest = pressures[..nf]
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    if lowest.is_finite() {
        for p in pressures.iter_mut() {
            *p -= lowest;
        }
    }
}
