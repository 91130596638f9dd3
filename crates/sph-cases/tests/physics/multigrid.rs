//! The multigrid's iteration count through the path a run takes: the periodic Taylor–Green
//! vortex (`cases/hard/taylor_green.toml`, Wendland C2, closed: the bordered mean-zero gauge),
//! three DG steps solved by BiCGSTAB + AMG to 1e-6.

use crate::support::run;
use sph_cases::Scene;
use sph_integrators::SchemeKind;

/// Mean AMG iterations per step of three DG steps of the Taylor–Green scene at `dx`.
fn iterations(dx: f64) -> f64 {
    let text = include_str!("../../../../cases/hard/taylor_green.toml")
        .replacen("dx = 0.02", &format!("dx = {dx}"), 1)
        .replacen("dt = 5e-4", "dt = 1e-4", 1)
        .replacen(
            "t_end = 2.0",
            "t_end = 3e-4\nsolver = \"bicgstab_amg\"\nsolver_tolerance = 1e-6",
            1,
        );
    let scene = Scene::parse("taylor_green", &text).unwrap();
    assert!(
        scene.dx == dx && scene.dt == 1e-4 && scene.t_end == 3e-4,
        "the scene's text changed"
    );
    let (out, _) = run(&scene, SchemeKind::Dg);
    assert!(out.failure.is_none(), "{:?}", out.failure);
    out.results["solver_iterations_mean"]
}

/// From 10⁴ to 2.5·10⁵ unknowns (the hierarchy two levels deeper) the iterations per step
/// grow by less than 1.3×: measured 6.3 → 7.0 (1.11×) with the W-cycle on the coarse levels of
/// the deeper hierarchy, 6.3 → 11.0 (1.75×) with the former V-cycle.
#[test]
fn amg_iterations_stay_flat_from_1e4_to_2_5e5_unknowns() {
    let (small, large) = (iterations(0.01), iterations(0.002));
    assert!(
        large < 1.3 * small,
        "{small} iterations per step at 10⁴ unknowns, {large} at 2.5·10⁵"
    );
}
