//! Flows posed by scene blocks (walls with a free surface), through the path users take: a
//! TOML scene, the registry, the run loop.

use crate::support::run;
use sph_cases::registry::parse_scene;
use sph_integrators::SchemeKind;

/// A circle of fluid falling onto the floor of an open tank, in `dim` dimensions.
fn falling_drop(dim: usize, dx: f64, extra: &str) -> String {
    let v = |a: f64, b: f64, c: f64| {
        if dim == 2 {
            format!("[{a}, {b}]")
        } else {
            format!("[{a}, {b}, {c}]")
        }
    };
    format!(
        "dim = {dim}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 1e-3\nt_end = 0.5\nschemes = [\"euler\", \"predictor_corrector\", \"dg\"]\n{extra}\n\
         [[fluid]]\nshape = \"circle\"\ncenter = {}\nradius = 0.2\n\
         [[wall]]\nmin = {}\nmax = {}\nopen = [\"+y\"]\n\
         [free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\nshifting = {{ coefficient = 2.0 }}\n",
        v(0.5, 0.6, 0.5),
        v(0.0, 0.0, 0.0),
        v(1.0, 1.2, 1.0),
    )
}

/// A scene's point `[a, b]` in 2D, `[a, b, a]` in 3D.
fn point(dim: usize, a: f64, b: f64) -> String {
    if dim == 2 {
        format!("[{a}, {b}]")
    } else {
        format!("[{a}, {b}, {a}]")
    }
}

/// Total energy `KE + M g y_c` over the records of a run.
fn energies(sink: &sph_cases::run::MemorySink, mass: f64) -> Vec<(f64, f64)> {
    let t = sink.column("t");
    let ke = sink.column("kinetic_energy");
    let yc = sink.column("centroid_y");
    t.into_iter()
        .zip(ke.iter().zip(&yc).map(|(k, y)| k + mass * 9.81 * y))
        .collect()
}

/// The drop hits the floor at t ≈ 0.26 with |u| ≈ 2.6 and splashes. With the flow scenes'
/// operators (the symmetric gradient, the negative adjoint of the divergence) the projection
/// never raises the total energy, and no particle enters the walls; every scheme completes.
#[test]
fn a_drop_hitting_a_wall_gains_no_energy() {
    let scene = parse_scene("drop on a wall", &falling_drop(2, 0.04, "")).unwrap();
    for kind in SchemeKind::ALL {
        let (out, sink) = run(&scene, kind);
        assert!(out.failure.is_none(), "{kind:?}: {:?}", out.failure);
        let mass = out.particles.0 as f64 * 0.04 * 0.04;
        let e = energies(&sink, mass);
        let e0 = e[0].1;
        let worst = e.iter().map(|(_, v)| v / e0 - 1.0).fold(f64::MIN, f64::max);
        assert!(
            worst < 0.01,
            "{kind:?}: energy rose by {:.1} %",
            100.0 * worst
        );
        // The drop fell and hit: the energy fell after the impact.
        assert!(e.last().unwrap().1 < 0.9 * e0, "{kind:?}: {e:?}");
        assert_eq!(out.results["max_wall_penetrations"], 0.0, "{kind:?}");
    }
}

/// Shifting moves a particle by `δr` and carries its velocity along with the Taylor correction
/// `u += (∇u) δr`. At an impact `∇u` is large and, renormalised at a truncated support,
/// unreliable: with the paper's operators the correction alone raises the drop's total energy
/// many times over (the energy budget puts it in the regularisation term). Limited to the
/// range of the neighbours' velocities it creates no new extremum, and the energy never rises
/// (measured: never above its start for any scheme; with the Taylor correction +74 % to +241 %).
/// At dx = 0.04 (80 particles) the paper's projection itself adds energy at the impact, so the
/// test runs at dx = 0.02, and at the fixed step 1e-3: with the automatic step (down to 2.4e-4
/// in the splash) the paper's projection adds energy there too (Euler: +0.62 J/m of projection
/// work against −0.04 at 1e-3; docs/hard-cases.md), which is not what this test is about; nor
/// is the flow scenes' default hyperviscosity, which damps what the Taylor correction puts into
/// the particle scale (with it: +2.1 %, Euler), so the scene turns it off.
#[test]
fn a_limited_shift_correction_adds_no_energy_at_an_impact() {
    let worst_rise = |correction: &str, kind: SchemeKind| {
        let extra = "[time_step]\nauto = false\n[pressure]\ngradient = \"difference\"\nrenormalise = true\n";
        let text = falling_drop(2, 0.02, extra).replace(
            "shifting = { coefficient = 2.0 }",
            &format!(
                "shifting = {{ coefficient = 2.0, velocity_correction = \"{correction}\" }}\n\
                 hyperviscosity = {{ speed = 0.0 }}"
            ),
        );
        let scene = parse_scene("drop on a wall", &text).unwrap();
        let (out, sink) = run(&scene, kind);
        let mass = out.particles.0 as f64 * 0.02 * 0.02;
        let e = energies(&sink, mass);
        let e0 = e[0].1;
        (
            e.iter().map(|(_, v)| v / e0 - 1.0).fold(f64::MIN, f64::max),
            out,
        )
    };
    for kind in SchemeKind::ALL {
        let (limited, out) = worst_rise("limited", kind);
        assert!(out.failure.is_none(), "{kind:?}: {:?}", out.failure);
        assert!(
            limited < 0.01,
            "{kind:?}: limited: energy rose by {:.1} %",
            100.0 * limited
        );
        let (taylor, _) = worst_rise("taylor", kind);
        assert!(
            taylor > 0.1,
            "{kind:?}: taylor: energy rose by only {:.1} %",
            100.0 * taylor
        );
    }
}

/// The same drop in 3D, coarse.
#[test]
fn a_drop_hitting_a_wall_gains_no_energy_3d() {
    let scene = parse_scene(
        "drop on a wall 3d",
        &falling_drop(3, 0.1, "").replace("t_end = 0.5", "t_end = 0.4"),
    )
    .unwrap();
    let (out, sink) = run(&scene, SchemeKind::Dg);
    assert!(out.failure.is_none(), "{:?}", out.failure);
    let mass = out.particles.0 as f64 * 0.1f64.powi(3);
    let e = energies(&sink, mass);
    let worst = e
        .iter()
        .map(|(_, v)| v / e[0].1 - 1.0)
        .fold(f64::MIN, f64::max);
    assert!(worst < 0.01, "energy rose by {:.1} %", 100.0 * worst);
    assert_eq!(out.results["max_wall_penetrations"], 0.0);
}

sph_core::dim_tests! {
/// One projection of a uniform vertical stream in an open tank with a free surface: a wall
/// stops the fluid that moves into it, and leaves alone the fluid that moves away from it (it
/// must not pull it back with a negative pressure).
fn wall_lets_separating_fluid_go<D>() {
    use sph_core::VectorOps;
    use sph_integrators::{Integrator, Scheme};
    let dx = if D::DIM == 2 { 0.05 } else { 0.1 };
    let v = |a: f64, b: f64| point(D::DIM, a, b);
    for uy in [1.0, -1.0] {
        let text = format!(
            "dim = {}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 1e-3\nt_end = 0.01\nschemes = [\"euler\"]\n\
             [[fluid]]\nshape = \"box\"\nmin = {}\nmax = {}\nvelocity = {}\n\
             [[wall]]\nmin = {}\nmax = {}\nopen = [\"+y\"]\n[free_surface]\n",
            D::DIM,
            v(0.0, 0.0),
            v(1.0, 0.5),
            v(0.0, uy),
            v(0.0, 0.0),
            v(1.0, 1.0),
        );
        let scene = parse_scene("stream", &text).unwrap();
        let mut sim = sph_cases::flow::setup::<D>(&scene).unwrap().simulation().unwrap();
        Scheme::new(SchemeKind::Euler).step(&mut sim, 1e-3).unwrap();
        let nf = sim.fluid_len();
        let p = &sim.particles;
        // The first layer above the floor, away from the side walls.
        let floor: Vec<f64> = (0..nf)
            .filter(|&i| {
                let x = p.positions[i];
                x.get(1) < dx && (0..D::DIM).filter(|k| *k != 1).all(|k| x.get(k) > 0.3 && x.get(k) < 0.7)
            })
            .map(|i| p.velocities[i].get(1))
            .collect();
        assert!(!floor.is_empty());
        let mean = floor.iter().sum::<f64>() / floor.len() as f64;
        if uy > 0.0 {
            assert!(mean > 0.9, "separating stream pulled back: u_y = {mean}");
        } else {
            assert!(mean.abs() < 0.15, "stream into the floor not stopped: u_y = {mean}");
        }
    }
}
}

/// `[start] settle_steps`: the scheme runs that many steps before the clock starts, each
/// ending at rest, and the run then starts at t = 0, step 0, from rest, in the settled state:
/// a jittered tank's first record differs from the unsettled one in its positions (its
/// centroid) but not in its time, step or kinetic energy, and settling records nothing.
#[test]
fn settling_moves_the_start_and_keeps_the_clock() {
    let text = |settle: usize| {
        format!(
            "dim = 2\ndx = 0.05\nkernel = \"wendland_c2\"\ndt = 2e-3\nt_end = 0.01\n\
             schemes = [\"euler\"]\n\
             [pressure]\ngradient = \"difference\"\nrenormalise = true\n\
             [[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.6, 0.4]\nhydrostatic = true\njitter = 0.2\n\
             [[wall]]\nmin = [0.0, 0.0]\nmax = [0.6, 0.6]\nopen = [\"+y\"]\n\
             [free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\n\
             [start]\nsettle_steps = {settle}\n"
        )
    };
    let (plain, plain_sink) = run(&parse_scene("tank", &text(0)).unwrap(), SchemeKind::Euler);
    let (settled, sink) = run(&parse_scene("tank", &text(20)).unwrap(), SchemeKind::Euler);
    assert!(plain.failure.is_none() && settled.failure.is_none());
    assert_eq!(
        sink.column("t"),
        plain_sink.column("t"),
        "the same records at the same times"
    );
    assert_eq!(sink.column("step"), plain_sink.column("step"));
    assert_eq!(
        sink.column("kinetic_energy")[0],
        0.0,
        "the run starts from rest"
    );
    assert_eq!(settled.steps_taken, plain.steps_taken);
    let (y0, y1) = (
        plain_sink.column("centroid_y")[0],
        sink.column("centroid_y")[0],
    );
    assert!(
        y0 != y1,
        "settling moved the particles (centroid {y0} both times)"
    );
}

/// `[start] settle_damping = c`: each settling step ends with the fraction `c` of the fluid's
/// velocity removed. A drop with nothing under it falls freely while settling (its pressure
/// stays near zero), so its centroid drops by the damped free fall's distance: with the velocity
/// a step moves by `v_n = u_{n−1} + g Δt` and `u_n = (1 − c) v_n`, `v_n = (g Δt / c)(1 − (1 −
/// c)^n)` and `N` steps fall `Σ v_n Δt = (g Δt² / c)(N − (1 − c)(1 − (1 − c)^N) / c)`; `c = 1`
/// (the default) is `N g Δt²`. Euler's step, 2D and 3D.
#[test]
fn a_damped_settling_falls_as_damped_free_fall() {
    for dim in [2, 3] {
        let text = |steps: usize, damping: f64| {
            let dx = if dim == 2 { 0.04 } else { 0.05 };
            let extra = format!("[start]\nsettle_steps = {steps}\nsettle_damping = {damping}\n");
            falling_drop(dim, dx, &extra)
                .replace("t_end = 0.5", "t_end = 0.002")
                .replace(
                    "[\"euler\", \"predictor_corrector\", \"dg\"]",
                    "[\"euler\"]",
                )
        };
        let centroid = |steps: usize, damping: f64| {
            let scene = parse_scene("settled drop", &text(steps, damping))
                .unwrap_or_else(|e| panic!("{dim}D: {e}"));
            let (out, sink) = run(&scene, SchemeKind::Euler);
            assert!(out.failure.is_none(), "{dim}D: {:?}", out.failure);
            sink.column("centroid_y")[0]
        };
        let y0 = centroid(0, 1.0);
        let (g, dt, n) = (9.81, 1e-3, 60usize);
        for c in [1.0, 0.1] {
            let fell = y0 - centroid(n, c);
            let keep: f64 = 1.0 - c;
            let exact = g * dt * dt / c * (n as f64 - keep * (1.0 - keep.powi(n as i32)) / c);
            assert!(
                (fell / exact - 1.0).abs() < 1e-6,
                "{dim}D, c = {c}: fell {fell}, damped free fall {exact}"
            );
        }
    }
}

/// A drop falling into a pool: the pool is the hydrostatic block, the drop the other; they
/// first touch (a drop particle with a pool particle in its support) after the drop has fallen
/// the gap less about a support radius, `t = √(2 (gap − r) / g)`, and the pool's largest speed
/// before that, over `√(gH)`, is measured. The mechanical energy's rise is measured from the
/// start (heights from the floor).
#[test]
fn a_drop_meets_the_pool_when_it_has_fallen_the_gap() {
    let text = "dim = 2\ndx = 0.05\nkernel = \"wendland_c2\"\ndt = 1e-3\nt_end = 0.4\n\
                schemes = [\"euler\"]\n\
                [[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [2.0, 0.5]\nhydrostatic = true\n\
                [[fluid]]\nshape = \"circle\"\ncenter = [1.0, 1.2]\nradius = 0.2\n\
                [[wall]]\nmin = [0.0, 0.0]\nmax = [2.0, 2.0]\nopen = [\"+y\"]\n\
                [free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\n\
                [output]\nsample_every = 1\n";
    let (out, _) = run(&parse_scene("pool", text).unwrap(), SchemeKind::Euler);
    assert!(out.failure.is_none(), "{:?}", out.failure);
    let r = &out.results;
    // On the staggered lattice the drop's lowest particle sits at y = 1.025 (1.2 − 0.175) and
    // the pool's top row at 0.475; they touch when that gap has closed to the support radius
    // 2 h = 0.13.
    let gap: f64 = 1.025 - 0.475 - 0.13;
    let expected = (2.0 * gap / 9.81).sqrt();
    let t = r["t_contact"];
    assert!(
        (t - expected).abs() < 0.02,
        "contact at {t}, free fall says {expected}"
    );
    let pool = r["pool_speed_ratio_before_contact"];
    // The pool, not the falling drop (which reaches 2.4 = 1.1 √(gH) by then).
    assert!((0.0..0.1).contains(&pool), "{pool}");
    assert!(r["energy_rise_max"].is_finite());
    assert!(
        r["level_change_dx"].is_nan(),
        "not all blocks are hydrostatic"
    );
}

/// A still tank's first pressure solve, warm-started from the hydrostatic pressure, has a
/// right-hand side that is a small remainder of large pressures: its residual relative to the
/// right-hand side stagnates near 1.4e-11 whatever the solver does. Asked for 1e-13, the solve
/// used to fail at step 0 ("did not converge"); it now accepts the residual at the round-off
/// floor as a backward error (`CsrSystem::backward_error`), and the run goes on.
#[test]
fn a_solve_at_the_round_off_floor_is_accepted() {
    let text = "dim = 2\ndx = 0.05\nkernel = \"wendland_c2\"\ndt = 2e-3\nt_end = 0.004\n\
                schemes = [\"euler\"]\nsolver_tolerance = 1e-13\n\
                [[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [2.0, 1.0]\nhydrostatic = true\n\
                [[wall]]\nmin = [0.0, 0.0]\nmax = [2.0, 1.5]\nopen = [\"+y\"]\n\
                [free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\n\
                [output]\nsample_every = 1\n";
    let (out, sink) = run(&parse_scene("tank", text).unwrap(), SchemeKind::Euler);
    assert!(out.failure.is_none(), "{:?}", out.failure);
    let residual = sink.column("solver_residual")[1];
    assert!(
        residual > 1e-12,
        "the first solve's residual {residual} is not at the floor"
    );
}

/// A flow resumed from an early checkpoint reports the whole run's results — maxima over the
/// records before the checkpoint, the values taken at the (settled) start — equal to the
/// uninterrupted run's bit for bit (wall-clock results aside): the checkpoint carries the
/// case's accumulated state. A jittered, settled tank under gravity, every scheme, 2D and 3D.
fn a_resumed_flow_reports_the_whole_runs_results(dim: usize) {
    let (fill, tank, dx) = if dim == 2 {
        (
            "[0.0, 0.0]\nmax = [0.6, 0.4]",
            "[0.0, 0.0]\nmax = [0.6, 0.6]",
            0.05,
        )
    } else {
        (
            "[0.0, 0.0, 0.0]\nmax = [0.4, 0.3, 0.2]",
            "[0.0, 0.0, 0.0]\nmax = [0.4, 0.4, 0.2]",
            0.1,
        )
    };
    let text = format!(
        "dim = {dim}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 2e-3\nt_end = 0.04\n\
         schemes = [\"euler\"]\n\
         [[fluid]]\nshape = \"box\"\nmin = {fill}\nhydrostatic = true\njitter = 0.1\n\
         [[wall]]\nmin = {tank}\nopen = [\"+y\"]\n\
         [free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\nshifting = {{ coefficient = 2.0 }}\n\
         [start]\nsettle_steps = 3\n\
         [output]\nsample_every = 1\n"
    );
    let scene = parse_scene("tank", &text).unwrap();
    for scheme in SchemeKind::ALL {
        let control = |resume| sph_cases::run::RunControl {
            resume,
            checkpoint_every: Some(5),
            checkpoint_meta: "test".into(),
            stop: None,
        };
        let (straight, sink) = crate::support::run_with(&scene, scheme, control(None));
        assert!(
            straight.failure.is_none(),
            "{scheme:?}: {:?}",
            straight.failure
        );
        let (resumed, _) =
            crate::support::run_with(&scene, scheme, control(Some(&sink.checkpoints[0])));
        let untimed = crate::support::untimed_results;
        assert_eq!(untimed(&resumed), untimed(&straight), "{dim}D {scheme:?}");
        // Without the state (a checkpoint of format 2) the resumed run's results cover only
        // its own segment, and differ: the comparison above is not one any resumed run passes.
        let mut bare = sink.checkpoints[0].clone();
        bare.state.clear();
        let (partial, _) = crate::support::run_with(&scene, scheme, control(Some(&bare)));
        assert_ne!(untimed(&partial), untimed(&straight), "{dim}D {scheme:?}");
    }
}

#[test]
fn a_resumed_flow_reports_the_whole_runs_results_d2() {
    a_resumed_flow_reports_the_whole_runs_results(2);
}

#[test]
fn a_resumed_flow_reports_the_whole_runs_results_d3() {
    a_resumed_flow_reports_the_whole_runs_results(3);
}

sph_core::dim_tests! {
/// `[start] relax_iterations`: a 20 % jittered tank is packed before the clock starts. The
/// first step's interior density error (summation density: the disorder) falls, the level
/// (centroid height) moves by less than a tenth of a spacing (the surface is not spread), and
/// the run starts at t = 0 from rest. In 2D the symmetric pressure gradient without its level
/// term blows the unrelaxed tank up within 10 steps and carries the relaxed one through them
/// (docs/hard-cases.md: the projection's amplification on disordered particles); with it (the
/// flow scenes' default) the unrelaxed tank runs through them too (docs/physics.md, "The
/// symmetric gradient at a pressure level").
fn relaxation_packs_a_jittered_tank_before_the_clock<D>() {
    let dx = if D::DIM == 2 { 0.05 } else { 0.1 };
    let v = |a: f64, b: f64| point(D::DIM, a, b);
    let text_with = |relax: usize, level: bool| {
        format!(
            "dim = {}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 2e-3\nt_end = 0.02\n\
             schemes = [\"euler\"]\n[pressure]\nlevel_consistent = {level}\n\
             [[fluid]]\nshape = \"box\"\nmin = {}\nmax = {}\nhydrostatic = true\njitter = 0.2\n\
             [[wall]]\nmin = {}\nmax = {}\nopen = [\"+y\"]\n\
             [free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\nshifting = {{ coefficient = 2.0 }}\n\
             [output]\nsample_every = 1\n\
             [start]\nrelax_iterations = {relax}\n",
            D::DIM,
            v(0.0, 0.0),
            v(2.0, 1.0),
            v(0.0, 0.0),
            v(2.0, 1.5),
        )
    };
    let text = |relax: usize| text_with(relax, true);
    let (plain, plain_sink) = crate::support::run(&parse_scene("tank", &text(0)).unwrap(), SchemeKind::Euler);
    let (relaxed, sink) = crate::support::run(&parse_scene("tank", &text(60)).unwrap(), SchemeKind::Euler);
    assert!(relaxed.failure.is_none(), "{:?}", relaxed.failure);
    assert_eq!(sink.column("t")[0], 0.0);
    assert_eq!(sink.column("kinetic_energy")[0], 0.0, "the run starts from rest");
    let level = |s: &sph_cases::run::MemorySink| s.column("centroid_y")[0];
    let moved = (level(&sink) - level(&plain_sink)).abs();
    assert!(moved < 0.1 * dx, "the level moved {:.3} dx", moved / dx);
    let disorder = |s: &sph_cases::run::MemorySink| s.column("density_error")[1];
    let (before, after) = (disorder(&plain_sink), disorder(&sink));
    assert!(
        after < 0.7 * before,
        "interior density error {before:.4} unrelaxed, {after:.4} relaxed"
    );
    if D::DIM == 2 {
        assert!(plain.failure.is_none(), "the unrelaxed 2D tank: {:?}", plain.failure);
        let (no_level, _) =
            crate::support::run(&parse_scene("tank", &text_with(0, false)).unwrap(), SchemeKind::Euler);
        assert!(no_level.failure.is_some(), "without the level term the unrelaxed 2D tank ran through");
    }
}
}

sph_core::dim_tests! {
/// The automatic time step (the flow scenes' default): a collapsing column starts at rest, so
/// its first step is the body-force limit `0.25 √(h/g)`; once it moves, steps are the
/// advective limit `C_u h / max|u|` (`AutoTimeStep::default().advective`) of the speed at the
/// step's start (the previous record's,
/// one record per step), never above the scene's `dt`; the last step ends at `t_end`. The same
/// steps to the bit on 1 and 3 threads; with `auto = false` every step is `dt`. The scene
/// turns the flow scenes' default hyperviscosity off; with it, the first step is its limit
/// `Δt = K/(ν₄ λ²)` ([`Scene::limit_viscosity`](sph_cases::Scene::limit_viscosity)), tighter here
/// than the body force's.
fn the_automatic_step_is_the_binding_limit<D>() {
    let dx = if D::DIM == 2 { 0.05 } else { 0.1 };
    let h = 1.3 * dx;
    let v = |a: f64, b: f64| point(D::DIM, a, b);
    let text = |extra: &str| {
        format!(
            "dim = {}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 0.05\nt_end = 0.5\n\
             schemes = [\"euler\"]\n\
             [[fluid]]\nshape = \"box\"\nmin = {}\nmax = {}\nhydrostatic = true\n\
             [[wall]]\nmin = {}\nmax = {}\nopen = [\"+y\"]\n\
             [free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\n{{hv}}\n\
             [output]\nsample_every = 1\n{extra}",
            D::DIM,
            v(0.0, 0.0),
            v(0.4, 0.4),
            v(0.0, 0.0),
            v(1.2, 0.8),
        )
    };
    let off = "hyperviscosity = { speed = 0.0 }";
    // With the default hyperviscosity: its limit sets the first step.
    let default = parse_scene("column", &text("").replace("{hv}", "")).unwrap();
    let (out, sink) = crate::support::run(&default, SchemeKind::Euler);
    assert!(out.failure.is_none(), "{:?}", out.failure);
    let auto = sph_integrators::AutoTimeStep::default();
    let limit = auto.viscous * h * h / default.limit_viscosity(&auto);
    let force = 0.25 * (h / 9.81f64).sqrt();
    let (dt1, bound1) = (sink.column("dt")[1], sink.column("dt_bound")[1]);
    println!("{}: default first step {dt1:.4e} (bound {bound1}), the body force's {force:.4e}", D::NAME);
    assert!(limit < force && (dt1 - limit).abs() <= 1e-14 * limit && bound1 == 2.0, "{dt1} {limit}");
    let text = |extra: &str| text(extra).replace("{hv}", off);
    let scene = parse_scene("column", &text("")).unwrap();
    let go = |threads: usize| crate::support::run_on_threads(&scene, SchemeKind::Euler, threads);
    let (out, sink) = go(1);
    assert!(out.failure.is_none(), "{:?}", out.failure);
    assert_eq!(out.t, 0.5, "the last step ends at t_end");
    let (dt, bound, speed) = (
        sink.column("dt"),
        sink.column("dt_bound"),
        sink.column("max_speed"),
    );
    assert_eq!((dt[1], bound[1]), (force, 3.0), "the first step, from rest");
    // Each step is its binding limit L until at most `END_STEPS` such steps remain; from there
    // the rest is spread equally, `remaining / ⌈remaining / L⌉`, which is never longer than L
    // nor shorter than `(m − 1) / m` of it (m the steps left).
    use sph_cases::run::END_STEPS;
    let time = sink.column("t");
    let mut advective = 0;
    let mut spread = 0;
    let n = dt.len();
    for k in 1..n {
        let limit = match bound[k] {
            1.0 => sph_integrators::AutoTimeStep::default().advective * h / speed[k - 1],
            3.0 => force,
            b => panic!("step {k}: bound {b}"),
        };
        assert!(limit < 0.05 && dt[k] <= limit * (1.0 + 1e-14), "step {k}: {} > {limit}", dt[k]);
        let remaining = 0.5 - time[k - 1];
        if remaining > END_STEPS as f64 * limit {
            assert!((dt[k] - limit).abs() <= 1e-14 * limit, "step {k}: {} ≠ {limit}", dt[k]);
            advective += usize::from(bound[k] == 1.0);
        } else {
            let m = (remaining / limit).ceil();
            let equal = remaining / m;
            assert!((dt[k] - equal).abs() <= 1e-12 * equal, "step {k}: {} ≠ {equal}", dt[k]);
            assert!(m == 1.0 || dt[k] >= limit * (m - 1.0) / m, "step {k}");
            spread += 1;
        }
    }
    assert!(spread >= END_STEPS / 2, "{spread} steps spread the end");
    assert!(advective >= 5, "the flow accelerates: {advective} advective steps");
    assert!(out.results["dt_min"] < out.results["dt_max"]);
    let (_, sink3) = go(3);
    let bits = |s: &sph_cases::run::MemorySink| {
        s.column("dt").iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    };
    assert!(bits(&sink) == bits(&sink3), "steps differ between 1 and 3 threads");
    let fixed = parse_scene("column", &text("[time_step]\nauto = false\n")).unwrap();
    let (_, sink) = crate::support::run(&fixed, SchemeKind::Euler);
    let dt = sink.column("dt");
    assert!(dt[1..].iter().all(|&d| (d - 0.05).abs() < 1e-15), "{dt:?}");
    assert!(sink.column("dt_bound")[1..].iter().all(|b| b.is_nan()));
}
}

/// A flow that runs away under the automatic step (the Taylor–Green vortex without shifting,
/// quick preset: particles gather on the stagnation lines) is stopped as a blow-up once its
/// fastest particle passes `[limits] max_speed_ratio` (default 50) times the flow's velocity
/// scale (here the initial largest speed), naming the particle; the shrinking step would
/// otherwise follow its speed without any step moving a particle further than `h`.
#[test]
fn a_runaway_flow_stops_when_its_speed_passes_the_limit() {
    use sph_cases::DEFAULT_MAX_SPEED_RATIO;
    use sph_integrators::StepError;
    let text = include_str!("../../../../cases/hard/taylor_green_no_shift.toml");
    let scene = parse_scene("taylor_green_no_shift", text).unwrap().quick();
    let (out, sink) = crate::support::run(&scene, SchemeKind::Euler);
    let u0 = sink.column("max_speed")[0];
    match out.failure {
        Some(StepError::SpeedRunaway {
            speed,
            scale,
            limit,
            particle,
            ..
        }) => {
            assert_eq!(limit, DEFAULT_MAX_SPEED_RATIO);
            assert_eq!(scale, u0);
            assert!(speed > limit * scale, "speed {speed}, scale {scale}");
            assert!(particle < 10_000, "particle {particle}");
        }
        other => panic!("expected the speed limit to stop the run: {other:?}"),
    }
    // Stopped before the step after the first state past the limit: only the last record, if
    // any, is over it.
    let speeds = sink.column("max_speed");
    let over = speeds
        .iter()
        .filter(|&&u| u > DEFAULT_MAX_SPEED_RATIO * u0)
        .count();
    assert!(over <= 1, "{over} records over the limit");
    assert!(
        speeds[..speeds.len() - 1]
            .iter()
            .all(|&u| u <= DEFAULT_MAX_SPEED_RATIO * u0)
    );
    assert!(out.t < 1.0, "t = {}", out.t);
}

/// With the speed limit lifted, the same runaway is stopped when the automatic step falls below
/// `COLLAPSE_FRACTION` of the run's largest, naming the limit that binds (without either check
/// its speed reached 1e26 in steps of 1e-28).
#[test]
fn a_runaway_flow_stops_when_the_automatic_step_collapses() {
    use sph_integrators::{COLLAPSE_FRACTION, DtBound, StepError};
    let text = include_str!("../../../../cases/hard/taylor_green_no_shift.toml");
    let mut scene = parse_scene("taylor_green_no_shift", text).unwrap().quick();
    scene.limits.max_speed_ratio = Some(1e300);
    let (out, _) = crate::support::run(&scene, SchemeKind::Euler);
    match out.failure {
        Some(StepError::TimeStepCollapse {
            dt,
            largest,
            speed,
            bound,
            ..
        }) => {
            assert!(dt < COLLAPSE_FRACTION * largest);
            assert_eq!(bound, DtBound::Advective);
            assert!(speed > 100.0, "speed {speed}");
        }
        other => panic!("expected the step to collapse: {other:?}"),
    }
    assert!(out.t < 1.0, "t = {}", out.t);
}

sph_core::dim_tests! {
/// A sealed tank full of water at rest under gravity (walls on every side, no free surface, the
/// flow scenes' defaults) stays at rest for every scheme to round-off: on a lattice its largest
/// speed stays under 1e-8 m/s to t = 3 (2D) and t = 2 (3D), measured 8e-13 to 5e-12. Without a
/// free surface the flow scenes take the renormalised difference pair: exact for the
/// hydrostatic field and blind to the pressure's level, which a closed domain leaves arbitrary.
/// From a start jittered by 20 % of dx and packed it holds to round-off (checked to t = 1) with
/// the consistent Laplacian (`[pressure] consistent_laplacian`), whose Laplacian of a linear
/// field vanishes on any particle set: measured 4e-13 m/s (2D) and 4e-12 (3D) to t = 3; with
/// Morris' the same start moves at 0.02 m/s by t = 3 (2D), with the symmetric set at 0.14. The
/// symmetric gradient chosen by a key holds the lattice tank by its lift to a lowest pressure of
/// 0 (a mean-zero level put the upper half under tension and blew the 2D tank up at t = 0.23),
/// to t = 0.5, under 1 % of √(gH) (docs/physics.md, "The flow scenes' numerics").
fn a_sealed_tank_under_gravity_stays_at_rest<D>() {
    let (dx, t_end) = if D::DIM == 2 { (0.05, 3.0) } else { (0.1, 2.0) };
    let v = |a: f64, b: f64| point(D::DIM, a, b);
    let (lo, hi) = (v(0.0, 0.0), v(0.6, 1.0));
    let text = format!(
        "dim = {}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 4e-3\nt_end = {t_end}\n\
         schemes = [\"euler\", \"predictor_corrector\", \"dg\"]\n\
         [[fluid]]\nshape = \"box\"\nmin = {lo}\nmax = {hi}\nhydrostatic = true\n\
         [[wall]]\nmin = {lo}\nmax = {hi}\n\
         [effects]\ngravity = [0.0, -9.81, 0.0]\nshifting = {{ coefficient = 2.0 }}\n\
         [output]\nsample_every = 1\n",
        D::DIM,
    );
    // Each variant edits the scene text; an edit that finds nothing would test the default again.
    let edit = |text: &str, from: &str, to: &str| {
        assert!(text.contains(from), "the scene has no {from:?}");
        text.replace(from, to)
    };
    let held = |text: &str, what: &str, limit: f64| {
        let scene = parse_scene(what, text).unwrap();
        for kind in SchemeKind::ALL {
            let (out, sink) = crate::support::run(&scene, kind);
            assert!(out.failure.is_none(), "{what}, {kind:?}: {:?}", out.failure);
            let fastest = sink.column("max_speed").into_iter().fold(0.0, f64::max);
            assert!(fastest < limit, "{what}, {kind:?}: largest speed {fastest:.3e} m/s");
        }
    };
    held(&text, "sealed tank, lattice", 1e-8);
    let jittered = edit(&text, &format!("t_end = {t_end}\n"), "t_end = 1.0\n");
    let jittered = edit(&jittered, "hydrostatic = true\n", "hydrostatic = true\njitter = 0.2\n");
    let jittered = edit(
        &jittered,
        "[effects]",
        "[start]\nrelax_iterations = 60\n[pressure]\nconsistent_laplacian = true\n[effects]",
    );
    held(&jittered, "sealed tank, jittered", 1e-8);
    // The symmetric gradient chosen for the same tank on a lattice holds it through the lift to
    // t = 0.5, under 1 % of √(gH) (2D: 8e-13 m/s; the rows start sliding from t ≈ 0.6).
    let symmetric = edit(&text, &format!("t_end = {t_end}\n"), "t_end = 0.5\n");
    let symmetric = edit(
        &symmetric,
        "[effects]",
        "[pressure]\ngradient = \"symmetric\"\n[effects]",
    );
    held(&symmetric, "sealed tank, symmetric", 0.01 * 9.81_f64.sqrt());
}
}

/// An open tank 1 × 1 (× 1) filled to the top on a lattice (dx = 0.05 in 2D, 0.1 in 3D), at rest
/// with its hydrostatic pressure, under gravity, Wendland C2, shifting, every step recorded, to
/// `t_end`; `free_surface` is the body of its `[free_surface]` table.
fn open_lattice_tank<D: sph_core::Dim>(t_end: f64, free_surface: &str) -> String {
    let dx = if D::DIM == 2 { 0.05 } else { 0.1 };
    let v = |a: f64, b: f64| point(D::DIM, a, b);
    format!(
        "dim = {}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 2e-3\nt_end = {t_end}\n\
         schemes = [\"euler\", \"predictor_corrector\", \"dg\"]\n\
         [[fluid]]\nshape = \"box\"\nmin = {}\nmax = {}\nhydrostatic = true\n\
         [[wall]]\nmin = {}\nmax = {}\nopen = [\"+y\"]\n\
         [free_surface]\n{free_surface}\n\
         [effects]\ngravity = [0.0, -9.81, 0.0]\nshifting = {{ coefficient = 2.0 }}\n\
         [output]\nsample_every = 1\n",
        D::DIM,
        v(0.0, 0.0),
        v(1.0, 1.0),
        v(0.0, 0.0),
        v(1.0, 1.5),
    )
}

sph_core::dim_tests! {
/// `[free_surface] extrapolate` with the symmetric gradient and its level term (the flow scenes'
/// defaults): an open tank on a lattice under gravity, whose surface particles
/// carry `ρ g dx/2` instead of 0, stays below 1 % of √(gH) to t = 0.5 (every scheme, 2D and 3D),
/// where `p = 0` at the top particles lets the surface row sink (it feels half the pressure
/// gradient it needs) at over 3 %. Without the default hyperviscosity, which calms the plain
/// rows too (0.088 m/s, Euler, 2D): the test is about the rows.
fn robin_rows_with_the_level_term_hold_an_open_tank_at_rest<D>() {
    let text = |robin: bool| {
        open_lattice_tank::<D>(0.5, &format!("extrapolate = {robin}")).replace(
            "shifting = { coefficient = 2.0 }",
            "shifting = { coefficient = 2.0 }\nhyperviscosity = { speed = 0.0 }",
        )
    };
    for kind in SchemeKind::ALL {
        let fastest = |robin: bool| {
            let (out, sink) = crate::support::run(&parse_scene("open tank", &text(robin)).unwrap(), kind);
            assert!(out.failure.is_none(), "{kind:?}: {:?}", out.failure);
            sink.column("max_speed").into_iter().fold(0.0, f64::max)
        };
        // Measured to t = 0.5 (the band's rows completed with the Robin rows, their default):
        // 0.012 against 0.170 m/s (2D), 0.014 against 0.124 (3D).
        let (plain, robin) = (fastest(false), fastest(true));
        let scale = 9.81_f64.sqrt();
        assert!(robin < 0.01 * scale, "{kind:?}: with the Robin rows {robin:.4} m/s");
        assert!(plain > 0.03 * scale, "{kind:?}: without them {plain:.4} m/s");
    }
}
}

/// The rotating square's centre pressure after step 10 (`rotating_square.toml`'s check, the
/// Poisson solution `−0.14734 ρω²L²` as reference) converges with `dx` once the pressure
/// gradient is normalised (`[pressure] normalise_gradient`, the flow scenes' default): measured
/// at dx = 0.05 / 0.025, Euler, −0.45 / −0.21 % with `p = 0` on the surface particles and
/// 1.33 / 0.71 % with the Robin rows. With the plain symmetric gradient the Robin rows' error is
/// 2.72 / 2.70 %, the kernel's lattice factor (`1/β − 1` = 2.68 % for Wendland C2 at
/// h = 1.3 dx: the projection removes the fraction β of the divergence per step and the pressure
/// settles 1/β high), and the surface particles' `p = 0` (the edge half a spacing in) offsets it
/// to 0.95 / 1.78 %, a value growing towards 2.7 % as dx falls. Every scheme.
#[test]
fn the_rotating_squares_centre_pressure_converges_with_the_normalised_gradient() {
    let text = |dx: f64, normalise: bool, robin: bool| {
        format!(
            "dim = 2\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 1e-3\nt_end = 0.012\n\
             schemes = [\"euler\", \"predictor_corrector\", \"dg\"]\n\
             [[fluid]]\nshape = \"box\"\nmin = [-0.5, -0.5]\nmax = [0.5, 0.5]\n\
             velocity_field = {{ kind = \"rigid_rotation\", omega = 1.0, center = [0.0, 0.0] }}\n\
             [free_surface]\nextrapolate = {robin}\n\
             [pressure]\nnormalise_gradient = {normalise}\n\
             [effects]\nshifting = {{ coefficient = 2.0 }}\n"
        )
    };
    for kind in SchemeKind::ALL {
        let error = |dx: f64, normalise: bool, robin: bool| {
            let scene = parse_scene("rotating square", &text(dx, normalise, robin)).unwrap();
            let (out, _) = run(&scene, kind);
            assert!(out.failure.is_none(), "{kind:?}: {:?}", out.failure);
            out.results["centre_pressure_error"]
        };
        for robin in [false, true] {
            let (coarse, fine) = (error(0.05, true, robin), error(0.025, true, robin));
            assert!(fine.abs() < 0.01, "{kind:?} robin {robin}: {fine}");
            let ratio = fine / coarse;
            assert!(
                (0.35..0.65).contains(&ratio),
                "{kind:?} robin {robin}: {coarse} → {fine}, not first order"
            );
        }
        // The plain gradient's Robin error is the lattice factor's `1/β − 1` (2.68 %), β computed
        // by sph-operators for the scene's kernel and spacing, not copied here.
        for dx in [0.05, 0.025] {
            let kernel = sph_kernels::KernelKind::WendlandC2.build::<sph_core::D2>(1.3 * dx);
            let beta = sph_operators::lattice_gradient_factor(&kernel, dx * dx);
            let plain = error(dx, false, true);
            assert!(
                (plain - (1.0 / beta - 1.0)).abs() < 0.001,
                "{kind:?} dx {dx}: plain Robin {plain} against 1/β − 1 = {}",
                1.0 / beta - 1.0
            );
        }
        let (coarse, fine) = (error(0.05, false, false), error(0.025, false, false));
        assert!(
            fine > coarse + 0.005,
            "{kind:?}: plain, p = 0: {coarse} → {fine}"
        );
    }
}

sph_core::dim_tests! {
/// `[free_surface] complete_band`: the rows of the particles in the surface's band, which
/// without it read the air their supports miss as a zero flux (`p_j = p_i`), read it as `p = 0`
/// beyond a flat surface at their depth. On an open lattice tank at rest under gravity, with
/// the flow defaults' Robin rows, the pressure the first steps solve for is then closer to
/// `ρ g (H − y)` (RMS over the fluid, largest over four steps; every scheme, 2D and 3D): measured
/// 0.31 against 0.52 % of ρgH in 2D, 0.49 against 0.64 % in 3D. Without the default
/// hyperviscosity, whose damping of the first steps' motion moves the pressure too (in 3D at
/// `C = 0.2 U`: 0.52 against 0.64 %): the test is about the rows.
fn completed_band_rows_bring_a_lattice_tanks_pressure_closer_to_hydrostatic<D>() {
    let text = |complete: bool| {
        open_lattice_tank::<D>(0.008, &format!("complete_band = {complete}")).replace(
            "shifting = { coefficient = 2.0 }",
            "shifting = { coefficient = 2.0 }\nhyperviscosity = { speed = 0.0 }",
        )
    };
    for kind in SchemeKind::ALL {
        let error = |complete: bool| {
            let scene = parse_scene("open tank", &text(complete)).unwrap();
            let (out, sink) = crate::support::run(&scene, kind);
            assert!(out.failure.is_none(), "{kind:?}: {:?}", out.failure);
            sink.column("hydrostatic_error").into_iter().filter(|e| e.is_finite()).fold(0.0, f64::max)
        };
        let (plain, completed) = (error(false), error(true));
        println!("{} {kind:?}: completed {completed:.5}, plain {plain:.5}", D::NAME);
        assert!(completed < 0.8 * plain, "{kind:?}: completed {completed:.5}, plain {plain:.5}");
    }
}
}

sph_core::dim_tests! {
/// A scene's `[effects] hyperviscosity`, through the path users take: the term runs (in its
/// own pass, and no viscous pass with it), the automatic step's first step is its limit `K/(ν₄ λ_G²)` where
/// that is below the body-force limit (`ν₄ = C h³`, `λ_G` from
/// `sph_operators::lattice_laplacian_bound`), as the scene's `step_bound` says, and the run (a jittered column collapsing) is the
/// same to the bit on 1 and 3 threads.
fn a_declared_hyperviscosity_runs_binds_the_step_and_keeps_the_bits<D>() {
    let dx = if D::DIM == 2 { 0.05 } else { 0.1 };
    let h = 1.3 * dx;
    let c = 1.0;
    let v = |a: f64, b: f64| point(D::DIM, a, b);
    let text = format!(
        "dim = {}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = 0.02\nt_end = 0.03\n\
         schemes = [\"euler\"]\n\
         [[fluid]]\nshape = \"box\"\nmin = {}\nmax = {}\nhydrostatic = true\njitter = 0.2\n\
         [[wall]]\nmin = {}\nmax = {}\nopen = [\"+y\"]\n\
         [free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\nhyperviscosity = {{ speed = {c} }}\n\
         [output]\nsample_every = 1\n",
        D::DIM,
        v(0.0, 0.0),
        v(0.4, 0.4),
        v(0.0, 0.0),
        v(1.2, 0.8),
    );
    let scene = parse_scene("column", &text).unwrap();
    let go = |threads: usize| crate::support::run_on_threads(&scene, SchemeKind::Euler, threads);
    let (out, sink) = go(1);
    assert!(out.failure.is_none(), "{:?}", out.failure);
    let ran = |c: &str| sink.column(c).iter().skip(1).any(|v| !v.is_nan());
    assert!(ran("seconds_hyperviscosity"), "the hyperviscous term did not run");
    assert!(!ran("seconds_viscosity"), "a viscous pass ran in an inviscid scene");
    let kernel = sph_kernels::KernelKind::WendlandC2.build::<D>(h);
    let bound = sph_operators::lattice_laplacian_bound::<D, _>(&kernel, dx.powi(D::DIM as i32));
    let limit = sph_integrators::HYPERVISCOUS_STEP / (c * h.powi(3) * bound * bound);
    let force = 0.25 * (h / 9.81f64).sqrt();
    let (dt, b) = (sink.column("dt"), sink.column("dt_bound"));
    println!("{}: hyperviscous limit {limit:.4e}, body force {force:.4e}, first step {:.4e}", D::NAME, dt[1]);
    assert!(limit < force);
    assert!((dt[1] - limit).abs() <= 1e-12 * limit && b[1] == 2.0, "{} {}", dt[1], b[1]);
    // The scene's own bound (what `dgsph` estimates a run's steps from) knows the limit too.
    let (bound, by) = scene.step_bound();
    assert!((bound - limit).abs() <= 1e-12 * limit, "step_bound {bound:.4e}, limit {limit:.4e}");
    assert_eq!(by, Some(sph_integrators::DtBound::Viscous));
    let (_, sink3) = go(3);
    let bits = |s: &sph_cases::run::MemorySink| {
        ["kinetic_energy", "dt", "energy_explicit"]
            .iter()
            .flat_map(|c| s.column(c).iter().map(|x| x.to_bits()).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    };
    assert!(bits(&sink) == bits(&sink3), "records differ between 1 and 3 threads");
}
}
