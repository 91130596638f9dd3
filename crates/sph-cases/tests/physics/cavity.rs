//! Lid-driven cavity: walls, gauge, first step from rest, short runs.

use crate::support::{run, run_with};
use sph_cases::run::RunControl;
use sph_cases::{Scene, cavity};
use sph_core::{D2, D3, Dim, VectorOps};
use sph_integrators::{Diagnostics, Integrator, Scheme, SchemeKind, StepReport};
use sph_pressure::SolverKind;

fn scene(dim: usize, dx: f64, dt: f64, re: f64, shifting: bool) -> Scene {
    let fx = if shifting {
        "[effects]\nshifting = { coefficient = 2.0 }\n"
    } else {
        ""
    };
    Scene::parse(
        "test",
        &format!(
            "case = \"lid_driven_cavity\"\ndim = {dim}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = {dt}\nt_end = 1.0\nschemes = [\"dg\"]\nsolver_tolerance = 1e-9\n[cavity]\nreynolds = {re}\n{fx}"
        ),
    )
    .unwrap()
}

fn first_step<D: Dim>(kind: SchemeKind) -> (StepReport, f64) {
    let s = scene(
        D::DIM,
        if D::DIM == 2 { 0.05 } else { 0.125 },
        0.01,
        100.0,
        false,
    );
    let mut c = cavity::setup::<D>(&s).unwrap();
    c.config.diagnostics = Diagnostics::ALL;
    let mut sim = c.simulation().unwrap();
    let rep = Scheme::new(kind).step(&mut sim, 0.01).unwrap();
    let nf = sim.fluid_len();
    let p = &sim.particles.pressures[..nf];
    let range = p.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - p.iter().cloned().fold(f64::INFINITY, f64::min);
    (rep, range)
}

/// The first-step check: from rest, the DG pressure has the size of Euler's (a wrong
/// wall contribution to A would put an O(1) spurious det A − 1 at the lid and blow it up), the
/// step's mean det F is 1, and no particle crosses a wall.
fn dg_first_step_pressure_matches_euler<D: Dim>() {
    let (euler, pe) = first_step::<D>(SchemeKind::Euler);
    let (dg, pd) = first_step::<D>(SchemeKind::Dg);
    let ratio = pd / pe;
    assert!(
        (0.8..1.25).contains(&ratio),
        "DG/Euler pressure range {ratio}"
    );
    for r in [euler, dg] {
        assert_eq!(r.wall_penetrations, 0);
        assert!(
            r.det_f.is_some_and(|d| (d.mean - 1.0).abs() < 1e-3),
            "{:?}",
            r.det_f
        );
    }
}

#[test]
fn dg_first_step_pressure_matches_euler_d2() {
    dg_first_step_pressure_matches_euler::<D2>();
}

#[test]
fn dg_first_step_pressure_matches_euler_d3() {
    dg_first_step_pressure_matches_euler::<D3>();
}

/// A short run of every scheme: no wall penetration, no pressure drift, finite energy.
fn short_run_holds<D: Dim>(t_end: f64) {
    let dx = if D::DIM == 2 { 0.05 } else { 0.125 };
    let mut s = scene(D::DIM, dx, 0.01, 100.0, true);
    s.t_end = t_end;
    s.cavity.as_mut().unwrap().check_ghia = Some(false);
    for kind in SchemeKind::ALL {
        let (out, sink) = run(&s, kind);
        assert!(out.failure.is_none(), "{kind:?}: {:?}", out.failure);
        let ke = sink.last("kinetic_energy");
        assert!(ke.is_finite() && ke > 0.0);
        assert!(!out.checks.is_empty());
        for c in &out.checks {
            assert!(
                c.passed(),
                "{kind:?} {}: {} vs {:?}",
                c.name,
                c.value,
                c.criterion
            );
        }
    }
}

#[test]
fn short_run_holds_d2() {
    short_run_holds::<D2>(1.0);
}

#[test]
fn short_run_holds_d3() {
    short_run_holds::<D3>(0.2);
}

/// The ordering of the paper's Figs. 7 and 9: DG-ISPH's RMS density error (Eq. 31) below Euler's
/// and below predictor–corrector's. **Not reproduced** (so ignored; run with `--ignored`): at
/// 20², Re 400, Wendland C2, t = 2 with shifting the measured RMS errors are Euler 3.19e-2,
/// PC 3.04e-2, DG 3.23e-2 (reflection walls: 1.68e-2, 1.61e-2, 1.75e-2); under reflection, at
/// t = 10 (Re 100) Euler 3.04e-2, PC 3.12e-2, DG 2.91e-2, and without shifting all three agreed
/// to 1 % (1.17e-2 at t = 0.3) until they failed together at t ≈ 0.6.
/// At the paper's dx = 0.02 (t = 45), the RMS error averaged over t ∈ [10, 45], Euler / PC / DG,
/// with the default wall condition (continuation): Wendland C2 (A = 2) Re 400 0.0208 / 0.0214 /
/// 0.0209, Re 1000 0.0223 / 0.0232 / 0.0222; quintic (A = 10) Re 400 0.00971 / 0.00936 /
/// 0.00960, Re 1000 0.00906 / 0.00846 / 0.00875 — DG lowest in one of four, by 0.4 %. With the
/// reflection condition: Wendland Re 400 0.0204 / 0.0214 / 0.0201, Re 1000 0.0184 / 0.0189 /
/// 0.0185; re-running Re 400 after a change of summation order in the matrix–vector product
/// only (fae4385) gave 0.0204 / 0.0213 / 0.0206: the gaps are within round-off-driven
/// run-to-run spread.
/// The density error here is set by the walls, the gauge incompatibility and shifting, not by
/// the scheme's O(Δt²) volume error. See docs/validation.md ("Lid-driven cavity").
#[test]
#[ignore = "paper's density ordering not reproduced; evidence in the doc comment and docs/validation.md"]
fn dg_density_error_below_euler_and_pc() {
    let mut s = scene(2, 0.05, 0.01, 400.0, true);
    s.t_end = 2.0;
    let rms = |kind| run(&s, kind).1.last("density_error_rms");
    let (e, p, d) = (
        rms(SchemeKind::Euler),
        rms(SchemeKind::PredictorCorrector),
        rms(SchemeKind::Dg),
    );
    assert!(
        d < e && d < p,
        "RMS density error: Euler {e:.3e}, PC {p:.3e}, DG {d:.3e}"
    );
}

/// Checkpoint and resume in memory: resuming from the step-4 checkpoint gives the
/// uninterrupted run's state bit for bit, and its last record and tables; a checkpoint of
/// another scene is refused with an error, not a panic. (The path users take, through the
/// checkpoint file in a new process, is tested by the `dgsph` binary's tests.)
fn resumed_run_continues_bit_for_bit<D: Dim>() {
    let mut s = scene(
        D::DIM,
        if D::DIM == 2 { 0.1 } else { 0.25 },
        0.01,
        100.0,
        true,
    );
    s.t_end = 0.08;
    s.schemes = vec![SchemeKind::PredictorCorrector];
    let control = |resume| RunControl {
        resume,
        checkpoint_every: Some(4),
        checkpoint_meta: "test".into(),
        stop: None,
    };
    let (straight_run, straight) = run_with(&s, s.schemes[0], control(None));
    let saved = &straight.checkpoints;
    assert_eq!(saved.iter().map(|c| c.step).collect::<Vec<_>>(), [4, 8]);
    let (resumed_run, resumed) = run_with(&s, s.schemes[0], control(Some(&saved[0])));
    // The resumed run's results cover the whole run (the checkpoint carries what the first
    // segment measured): equal to the uninterrupted run's, timings aside.
    let untimed = crate::support::untimed_results;
    assert_eq!(untimed(&resumed_run), untimed(&straight_run));
    assert_eq!((resumed_run.steps_taken, resumed_run.segment_steps), (8, 4));
    assert_eq!(resumed.checkpoints.len(), 1);
    assert_eq!(resumed.checkpoints[0], saved[1], "resumed state differs");
    assert!(saved[1].positions != saved[0].positions, "the run moved");
    // Equal last records, except the wall-clock columns.
    let last = |m: &sph_cases::run::MemorySink| {
        let r = m.records.last().unwrap().clone();
        r.into_iter()
            .zip(&m.columns)
            .filter(|(_, c)| !c.contains("seconds"))
            .map(|(v, _)| v.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(last(&resumed), last(&straight));
    assert_eq!(resumed.tables.last(), straight.tables.last());
    // A checkpoint of a finer lattice does not fit.
    let mut finer = s.clone();
    finer.dx *= 0.5;
    let mut sink = sph_cases::run::MemorySink::default();
    let err = sph_cases::registry::run_scheme(
        &finer,
        s.schemes[0],
        sph_cases::reference::References::embedded(),
        control(Some(&saved[0])),
        &mut sink,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("resuming") && err.contains("entries"), "{err}");
}

#[test]
fn resumed_run_continues_bit_for_bit_d2() {
    resumed_run_continues_bit_for_bit::<D2>();
}

#[test]
fn resumed_run_continues_bit_for_bit_d3() {
    resumed_run_continues_bit_for_bit::<D3>();
}

/// `solver_warm_start = false` starts every pressure solve from zero: the same steps to the
/// solver's tolerance, with more iterations than from the last step's pressure. Measured with
/// BiCGSTAB and Jacobi, whose iterations show the start's distance: the default AMG takes 35
/// iterations over these five 3D steps from either start.
fn cold_start_solves_the_same_steps_with_more_iterations<D: Dim>() {
    let dx = if D::DIM == 2 { 0.05 } else { 0.125 };
    let mut totals = Vec::new();
    let mut velocities = Vec::new();
    for warm in [true, false] {
        let mut s = scene(D::DIM, dx, 0.01, 100.0, false);
        s.solver_warm_start = warm;
        s.solver = SolverKind::BicgstabJacobi;
        let c = cavity::setup::<D>(&s).unwrap();
        assert_eq!(c.config.warm_start, warm);
        let mut sim = c.simulation().unwrap();
        let mut scheme = Scheme::new(SchemeKind::Dg);
        let mut total = 0;
        for _ in 0..5 {
            total += scheme.step(&mut sim, 0.01).unwrap().solve.iterations;
        }
        totals.push(total);
        velocities.push(sim.particles.velocities.clone());
    }
    assert!(
        totals[0] < totals[1],
        "iterations warm {} vs cold {}",
        totals[0],
        totals[1]
    );
    let umax = velocities[0].iter().map(|u| u.length()).fold(0.0, f64::max);
    let diff = velocities[0]
        .iter()
        .zip(&velocities[1])
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0, f64::max);
    assert!(
        diff < 1e-6 * umax,
        "warm and cold velocities differ by {diff} (max |u| {umax})"
    );
}

#[test]
fn cold_start_solves_the_same_steps_with_more_iterations_d2() {
    cold_start_solves_the_same_steps_with_more_iterations::<D2>();
}

#[test]
fn cold_start_solves_the_same_steps_with_more_iterations_d3() {
    cold_start_solves_the_same_steps_with_more_iterations::<D3>();
}
