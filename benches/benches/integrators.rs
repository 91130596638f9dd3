//! One full time step of each scheme on the paper's drops (`integrators/<scheme>/<dim>/<n>`; the
//! 3D spheroid at dx = 0.05, 1/30 and 0.025)
//! and on the Re 100 lid-driven cavity at 100² and 200² with every solver, and at 500² and
//! 1000² with BiCGSTAB + AMG (`integrators/cavity_<solver>/<scheme>/<n>`; the larger sizes
//! take minutes: select one with a filter, e.g. `-- cavity_bicgstab_amg/dg/25`), diagnostics
//! off: the cost of DG relative to Euler and PC, and of a whole step at the sizes users run.
//! The timed step is the third of the run (two untimed steps first): step 1 from the initial
//! field is not representative (Euler's PPE source ∇·u* is ≈ 0 there, so its solve chases a
//! relative tolerance on a tiny vector).

use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use dgsph_benches::drop_scene;
use sph_cases::CaseKind;
use sph_cases::drop::initial;
use sph_core::{D2, D3, Dim};
use sph_integrators::{Integrator, Scheme, SchemeKind, Simulation};
use std::hint::black_box;

fn bench<D: Dim>(c: &mut Criterion, case: CaseKind, dx: f64) {
    let mut group = c.benchmark_group("integrators");
    group.sample_size(10);
    let scene = drop_scene(case, dx);
    let (particles, _) = initial::<D>(&scene);
    let n = particles.len();
    // Diagnostics are off by default: a step is what a run without [output] diagnostics does.
    let config = scene.sim_config();
    for kind in SchemeKind::ALL {
        group.bench_function(
            BenchmarkId::new(format!("{}/{}", kind.name(), D::NAME), n),
            |b| {
                b.iter_batched(
                    || {
                        let mut sim = Simulation::new(particles.clone(), config.clone()).unwrap();
                        for _ in 0..2 {
                            Scheme::new(kind).step(&mut sim, scene.dt).unwrap();
                        }
                        sim
                    },
                    |mut sim| {
                        black_box(
                            Scheme::new(kind)
                                .step(&mut sim, scene.dt)
                                .unwrap()
                                .solve
                                .iterations,
                        )
                    },
                    BatchSize::LargeInput,
                )
            },
        );
    }
    group.finish();
}

/// The Re 100 cavity (`cases/cavity_re100.toml`) at spacing `dx` with `solver`. The step keeps
/// the scene's lid Courant number `U Δt / dx = 1/4` or its viscous number `ν Δt / dx² = 1/4`,
/// whichever gives the smaller step: at 100² both are the scene's; below dx = ν/U = 0.01 the
/// viscous one sets it (the viscous term is explicit: the 500² cavity at `Δt = dx/4`, where
/// `ν Δt / dx² = 1.25`, blew up in its second step).
fn cavity(c: &mut Criterion, dx: f64, solver: &str) {
    let mut group = c.benchmark_group("integrators");
    group.sample_size(10);
    let text = include_str!("../../cases/cavity_re100.toml");
    let mut scene = sph_cases::registry::parse_scene("cavity_re100", text).unwrap();
    scene.dx = dx;
    let spec = scene.cavity.as_ref().expect("a cavity scene");
    let (u, nu) = (spec.lid_speed.abs(), spec.lid_speed.abs() / spec.reynolds);
    scene.dt = (0.25 * dx / u).min(0.25 * dx * dx / nu);
    scene.solver = match solver {
        "bicgstab_amg" => sph_pressure::SolverKind::BicgstabAmg,
        "gmres_amg" => sph_pressure::SolverKind::GmresAmg,
        _ => sph_pressure::SolverKind::BicgstabJacobi,
    };
    let refs = sph_cases::reference::References::embedded();
    let start = |kind: SchemeKind| {
        sph_cases::registry::case::<D2>(&scene, kind, refs)
            .setup()
            .unwrap()
            .simulation()
            .unwrap()
    };
    // The particle count (the benchmark's parameter) without stepping: a filtered run need not
    // step the sizes it skips.
    let n = start(SchemeKind::Dg).particles.len();
    for kind in SchemeKind::ALL {
        let setup = || {
            let mut sim = start(kind);
            for _ in 0..2 {
                Scheme::new(kind).step(&mut sim, scene.dt).unwrap();
            }
            sim
        };
        group.bench_function(
            BenchmarkId::new(format!("cavity_{solver}/{}", kind.name()), n),
            |b| {
                b.iter_batched(
                    setup,
                    |mut sim| {
                        black_box(
                            Scheme::new(kind)
                                .step(&mut sim, scene.dt)
                                .unwrap()
                                .solve
                                .iterations,
                        )
                    },
                    BatchSize::LargeInput,
                )
            },
        );
    }
    group.finish();
}

fn integrators(c: &mut Criterion) {
    for dx in [0.01, 0.005] {
        for solver in ["bicgstab_jacobi", "bicgstab_amg", "gmres_amg"] {
            cavity(c, dx, solver);
        }
    }
    for dx in [0.002, 0.001] {
        cavity(c, dx, "bicgstab_amg");
    }
    bench::<D2>(c, CaseKind::EllipticalDrop, 0.025);
    bench::<D2>(c, CaseKind::EllipticalDrop, 0.0125);
    // The spheroid at the coarse size, the quick preset's (dx = 1/30) and the paper's (0.025).
    for dx in [0.05, 1.0 / 30.0, 0.025] {
        bench::<D3>(c, CaseKind::SpheroidDrop, dx);
    }
}

criterion_group!(benches, integrators);
criterion_main!(benches);
