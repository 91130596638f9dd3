//! Relaxation of a disordered start: particle packing before the clock starts.
//!
//! A projection whose Laplacian is not the divergence of its gradient (every SPH projection on
//! the neighbour list's stencil) is only approximately a projection; on a strongly disordered
//! particle set its step map `I − G L⁻¹ D` has eigenvalues just outside the unit circle (a
//! 20 % jitter: growth 0.7–0.9 % per step, whatever the pair and Laplacian; measured in
//! `docs/hard-cases.md`), and a few packing iterations bring them back inside. This moves the
//! fluid particles only, by the shifting displacement with a fixed diffusion coefficient:
//!
//! ```text
//! δr_i = −β h² ∇C_i,   ∇C_i = Σ_j V_j (1 + 0.2 (W_ij/W(Δp))⁴) ∇W_ij   (Lind et al. 2012, Eq. 9)
//! ```
//!
//! with β = [`RELAX_COEFFICIENT`], on particles within a support of a free surface only the part
//! tangential to it (the fluid does not spread), at most 0.2 Δp per iteration and at most half the distance to a wall. Velocities
//! and pressures are left as they are.

use crate::error::StepError;
use crate::projection::prepare;
use crate::report::PhaseTimes;
use crate::schemes::constrain_shift;
use crate::simulation::{Simulation, engine_context};
use rayon::prelude::*;
use sph_core::{Dim, VectorOps};
use sph_operators::concentration_gradient;

/// β of the packing displacement `δr = −β h² ∇C`. Measured on the 20 % jittered quick tank of
/// `cases/hard/still_water.toml` (2D, walls, free surface): with β = 0.1 the largest shift of an
/// iteration falls to 0.6 % of `Δp` by iteration 20 and 0.3 % by 40; with 0.25 it stalls near
/// 0.8 %, and with 0.5 the row next to the floor slides 0.2 `Δp` every iteration without
/// settling (the wall particles stiffen the packing there and a larger step overshoots).
pub const RELAX_COEFFICIENT: f64 = 0.1;

/// Largest displacement of one packing iteration, as a fraction of `Δp`.
const MAX_RELAX_SHIFT: f64 = 0.2;

/// What [`Simulation::relax`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RelaxReport {
    /// Iterations made.
    pub iterations: usize,
    /// Largest fluid displacement of the first iteration, over `Δp`.
    pub first_shift: f64,
    /// Largest fluid displacement of the last iteration, over `Δp` (how far from packed).
    pub last_shift: f64,
}

impl<D: Dim> Simulation<D> {
    /// Packs the fluid particles by `iterations` shifting displacements with a fixed
    /// coefficient (module docs), before a run's clock starts: the positions change, the
    /// velocities, pressures, time and step do not. `spacing` is the initial particle spacing
    /// `Δp`. Neighbour-search failures are the error (as in a step).
    pub fn relax(&mut self, iterations: usize, spacing: f64) -> Result<RelaxReport, StepError> {
        self.ensure_buffers();
        let n = self.particles.len();
        self.buf.grad_c.resize(n, D::Vector::ZERO);
        let mut report = RelaxReport::default();
        let nf = self.engine.fluid;
        let h = self.engine.config.h;
        let cap = MAX_RELAX_SHIFT * spacing;
        let free = self.engine.config.free_surface.is_some();
        let mut phases = PhaseTimes::default();
        for it in 0..iterations {
            // Mirror ghosts follow the fluid as it moves.
            self.refresh_walls()?;
            let p = &self.particles;
            prepare(
                &mut self.engine,
                &p.positions,
                &p.masses,
                &p.densities,
                self.step,
                self.t,
                &mut phases,
            )?;
            let e = &self.engine;
            let x = &self.particles.positions;
            let grad_c = &mut self.buf.grad_c[..];
            sph_kernels::with_kernel!(&e.kernel, k => {
                let ctx = engine_context!(e, x, k);
                concentration_gradient(&ctx, spacing, grad_c);
            });
            let grad_c = &*grad_c;
            let disp = &mut self.buf.disp[..nf];
            disp.par_iter_mut()
                .enumerate()
                .with_min_len(1024)
                .for_each(|(i, d)| {
                    let dr = grad_c[i] * (-RELAX_COEFFICIENT * h * h);
                    // Within a support of the free surface only the part tangential to it:
                    // there −∇C points out of the truncated support and would spread the fluid.
                    let near_surface = free
                        && (e.dirichlet[i]
                            || e.neighbors.row(i).iter().any(|&j| e.dirichlet[j as usize]));
                    *d = constrain_shift(e, x, i, dr, near_surface, cap);
                });
            let largest = disp
                .iter()
                .map(|d| d.length_squared())
                .fold(0.0, f64::max)
                .sqrt()
                / spacing;
            if it == 0 {
                report.first_shift = largest;
            }
            report.last_shift = largest;
            report.iterations = it + 1;
            let periodic = self.engine.periodic;
            for (x, d) in self.particles.positions[..nf]
                .iter_mut()
                .zip(&self.buf.disp[..nf])
            {
                *x += *d;
                if let Some(per) = &periodic {
                    *x = per.wrap(*x);
                }
            }
        }
        self.refresh_walls()?;
        Ok(report)
    }
}

#[cfg(test)]
mod tests {
    use crate::simulation::engine_context;
    use crate::{FreeSurface, PeriodicAxes, SimConfig, Simulation};
    use sph_core::testing::SplitMix64;
    use sph_core::{Dim, ParticleSet, VectorOps};
    use sph_kernels::KernelKind;
    use sph_operators::concentration_gradient;

    const DX: f64 = 0.05;
    const SIDE: usize = 10;

    /// A lattice in the box `[0, SIDE·DX)^D` (cell centres), periodic along `axes`, jittered
    /// by up to `jitter`·DX per axis.
    fn block<D: Dim>(axes: [bool; 3], jitter: f64, free: bool) -> Simulation<D> {
        let mut rng = SplitMix64::new(7);
        let pts: Vec<D::Vector> = sph_core::testing::lattice::<D>(SIDE, DX)
            .into_iter()
            .map(|x| {
                let shift = 0.5 * SIDE as f64 * DX;
                x + D::Vector::from_fn(|_| shift) + rng.vector::<D>(-jitter * DX, jitter * DX)
            })
            .collect();
        let p = ParticleSet::<D>::from_positions(pts, DX.powi(D::DIM as i32), 1.0);
        let mut cfg = SimConfig::new(KernelKind::WendlandC2, 1.3 * DX);
        let hi = SIDE as f64 * DX;
        cfg.periodic = Some(PeriodicAxes {
            lo: [0.0; 3],
            hi: [hi; 3],
            axes,
        });
        if free {
            cfg.free_surface = Some(FreeSurface::default_for(D::DIM));
        }
        Simulation::new(p, cfg).unwrap()
    }

    fn all_periodic<D: Dim>() -> [bool; 3] {
        [true, true, D::DIM == 3]
    }

    /// Largest |∇C_i| (the concentration gradient) at the particles' positions.
    fn disorder<D: Dim>(sim: &mut Simulation<D>) -> f64 {
        crate::tests::prepare_here(sim);
        let p = &sim.particles;
        let e = &sim.engine;
        let mut g = vec![D::Vector::ZERO; p.len()];
        let ctx = engine_context!(e, &p.positions);
        concentration_gradient(&ctx, DX, &mut g);
        g.iter().map(|v| v.length()).fold(0.0, f64::max)
    }

    sph_core::dim_tests! {
        /// A 20 % jittered periodic block packs: the concentration gradient falls by more than
        /// tenfold in 40 iterations, the last iteration moves particles by under 1 % of Δp,
        /// and the velocities are untouched.
        fn relaxation_packs_a_jittered_block<D>() {
            let mut sim = block::<D>(all_periodic::<D>(), 0.2, false);
            let before = disorder(&mut sim);
            let r = sim.relax(40, DX).unwrap();
            let after = disorder(&mut sim);
            assert_eq!(r.iterations, 40);
            assert!(after < 0.1 * before, "|∇C| {before:.3} -> {after:.3}");
            assert!(r.last_shift < 0.01, "{r:?}");
            assert!(r.first_shift > 0.05, "{r:?}");
            assert!(sim.particles.velocities.iter().all(|u| *u == D::Vector::ZERO));
        }

        /// An unjittered slab, periodic along x (and z), with free surfaces at its bottom and top
        /// rows: nothing moves, because on a flat surface −∇C is normal to it and only the
        /// tangential part is kept (without that the surface rows would move out by 0.2 Δp).
        fn relaxation_does_not_spread_a_flat_free_surface<D>() {
            let mut sim = block::<D>([true, false, D::DIM == 3], 0.0, true);
            let x0 = sim.particles.positions.clone();
            let r = sim.relax(5, DX).unwrap();
            let moved = sim
                .particles
                .positions
                .iter()
                .zip(&x0)
                .map(|(a, b)| (*a - *b).length())
                .fold(0.0, f64::max);
            assert!(moved < 1e-12 * DX, "moved {moved:e}; {r:?}");
        }

        /// The same positions, to the bit, on 1 and 3 threads.
        fn relaxation_does_not_depend_on_thread_count<D>() {
            let run = |threads| {
                crate::tests::on_threads(threads, || {
                    let mut sim = block::<D>(all_periodic::<D>(), 0.2, false);
                    sim.relax(10, DX).unwrap();
                    sim.particles
                        .positions
                        .iter()
                        .flat_map(|x| x.to_array3())
                        .map(f64::to_bits)
                        .collect::<Vec<_>>()
                })
            };
            assert!(run(1) == run(3));
        }
    }
}
