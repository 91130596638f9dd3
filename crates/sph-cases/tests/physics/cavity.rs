//! Lid-driven cavity: walls, gauge, first step from rest, short runs.

use sph_cases::{Scene, cavity};
use sph_core::{D2, Dim, MatrixOps, VectorOps};
use sph_integrators::{Integrator, Scheme, SchemeKind, Simulation};
use sph_neighbors::{CellGrid, NeighborList, NeighborSearch};
use sph_operators::{SphContext, correction_matrices, divergence};

fn scene(dx: f64, dt: f64, re: f64) -> Scene {
    Scene::parse(
        "test",
        &format!(
            "case = \"lid_driven_cavity\"\ndim = 2\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = {dt}\nt_end = 1.0\nschemes = [\"dg\"]\n[cavity]\nreynolds = {re}\n"
        ),
    )
    .unwrap()
}

/// Renormalised divergence of the particle velocities over the fluid (walls at their velocity).
fn fluid_divergence<D: Dim>(sim: &Simulation<D>) -> Vec<f64> {
    let p = &sim.particles;
    let mut g = CellGrid::<D>::new();
    g.build(&p.positions, sim.support_radius()).unwrap();
    let mut nl = NeighborList::new();
    g.query(&p.positions, &mut nl);
    let vol: Vec<f64> = p
        .masses
        .iter()
        .zip(&p.densities)
        .map(|(m, r)| m / r)
        .collect();
    let ctx = SphContext::new(&p.positions, &vol, &nl, sim.kernel());
    let mut l = vec![D::Matrix::IDENTITY; p.len()];
    correction_matrices(&ctx, 1e-3, &mut l);
    let mut div = vec![0.0; p.len()];
    divergence(&ctx, &p.velocities, Some(&l), &mut div);
    div.truncate(sim.fluid_len());
    div
}

#[test]
fn first_step_from_rest_debug() {
    let s = scene(0.05, 0.01, 100.0);
    let c = cavity::setup::<D2>(&s).unwrap();
    let mut sim = Simulation::with_walls(c.particles, c.config, c.walls).unwrap();
    let mut sch = Scheme::new(SchemeKind::Euler);
    for step in 0..40 {
        let rep = sch.step(&mut sim, 0.01).unwrap();
        if step % 10 != 0 && step != 39 {
            continue;
        }
        let div = fluid_divergence(&sim);
        let p = &sim.particles;
        let mut worst: Vec<(f64, usize)> =
            div.iter().enumerate().map(|(i, d)| (d.abs(), i)).collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        let med = worst[worst.len() / 2].0;
        let p90 = worst[worst.len() / 10].0;
        eprintln!(
            "step {step} iters {} max_div {:.3e} median {med:.2e} p90 {p90:.2e} gauge {:.3e}",
            rep.solve.iterations, rep.max_div_u, rep.gauge_multiplier
        );
        for (d, i) in worst.iter().take(4) {
            eprintln!(
                "  x {:.3?} div {:.3e} u {:.3?} p {:.3e}",
                &p.positions[*i].to_array3()[..2],
                d,
                &p.velocities[*i].to_array3()[..2],
                p.pressures[*i]
            );
        }
    }
}
