//! The wall conditions against one projection with a known answer, in the closed unit box of the
//! cavity (walls at rest, viscosity negligible: Re = 1e9):
//!
//! * a uniform stream `u = e_x` must be stopped (`uⁿ⁺¹ = 0`, `p = ρ x/Δt`);
//! * fluid at rest under gravity must stay at rest (`p = ρ g·x`);
//! * a divergence-free field tangential to the walls (a Taylor–Green cell) must pass unchanged.
//!
//! `WallCondition::Continuation` (the default) meets the first two and converges on the third;
//! `WallCondition::Reflection` meets the third closely and
//! fails the first two: that leak is the wall crossing of the cavity runs it was used for.

use sph_cases::{Scene, cavity};
use sph_core::{Dim, VectorOps};
use sph_integrators::{Integrator, Scheme, SchemeKind, WallCondition};

enum Init {
    Stream,
    Rest,
    TaylorGreen,
}

/// One Euler projection step; returns `(x, u_before, u_after)` of the fluid particles.
#[allow(clippy::type_complexity)]
fn one_projection<D: Dim>(
    dx: f64,
    dt: f64,
    condition: WallCondition,
    init: Init,
) -> (Vec<D::Vector>, Vec<D::Vector>, Vec<D::Vector>) {
    let s = Scene::parse(
        "walls",
        &format!(
            "case = \"lid_driven_cavity\"\ndim = {}\ndx = {dx}\nkernel = \"wendland_c2\"\ndt = {dt}\nt_end = 1.0\nschemes = [\"euler\"]\nsolver_tolerance = 1e-9\n[cavity]\nreynolds = 1e9\n",
            D::DIM
        ),
    )
    .unwrap();
    let mut c = cavity::setup::<D>(&s).unwrap();
    let walls = c.walls.as_mut().unwrap();
    walls.condition = condition;
    walls.velocity.fill(D::Vector::ZERO);
    let nf = walls.first;
    let pi = std::f64::consts::PI;
    for (u, x) in c.particles.velocities[..nf]
        .iter_mut()
        .zip(&c.particles.positions[..nf])
    {
        let (a, b) = (pi * x.get(0), pi * x.get(1));
        *u = match init {
            Init::Stream => D::Vector::from_fn(|k| if k == 0 { 1.0 } else { 0.0 }),
            Init::Rest => D::Vector::ZERO,
            Init::TaylorGreen => D::Vector::from_fn(|k| match k {
                0 => a.sin() * b.cos(),
                1 => -a.cos() * b.sin(),
                _ => 0.0,
            }),
        };
    }
    if matches!(init, Init::Rest) {
        c.config.effects.gravity = Some([0.0, -9.81, 0.0]);
    }
    let x = c.particles.positions[..nf].to_vec();
    let u0 = c.particles.velocities[..nf].to_vec();
    let mut sim = c.simulation().unwrap();
    let rep = Scheme::new(SchemeKind::Euler).step(&mut sim, dt).unwrap();
    assert_eq!(rep.wall_penetrations, 0);
    (x, u0, sim.particles.velocities[..nf].to_vec())
}

/// Largest `|u_x|` of the particles within one spacing of the side walls `x = 0, 1`.
fn side_wall_normal_velocity<D: Dim>(dx: f64, x: &[D::Vector], u: &[D::Vector]) -> f64 {
    x.iter()
        .zip(u)
        .filter(|(x, _)| x.get(0) < dx || x.get(0) > 1.0 - dx)
        .map(|(_, u)| u.get(0).abs())
        .fold(0.0, f64::max)
}

/// RMS of `|a|` over the particles.
fn rms<D: Dim>(a: &[D::Vector]) -> f64 {
    (a.iter().map(|v| v.dot(*v)).sum::<f64>() / a.len() as f64).sqrt()
}

fn rms_difference<D: Dim>(a: &[D::Vector], b: &[D::Vector]) -> f64 {
    let s: f64 = a.iter().zip(b).map(|(a, b)| (*a - *b).dot(*a - *b)).sum();
    (s / a.len() as f64).sqrt()
}

sph_core::dim_tests! {
    /// Measured (2D dx = 0.05 / 3D dx = 0.1): Continuation leaves 0.020 / 0.042 of the stream in the
    /// first layer at the side walls (RMS over the box 0.027 / 0.074), Reflection 0.52 / 0.54.
    fn closed_walls_stop_a_uniform_stream<D>() {
        let dx = if D::DIM == 2 { 0.05 } else { 0.1 };
        let (x, _, u) = one_projection::<D>(dx, 0.01, WallCondition::Continuation, Init::Stream);
        let first_layer = side_wall_normal_velocity::<D>(dx, &x, &u);
        let r = rms::<D>(&u);
        assert!(
            first_layer < 0.06,
            "continuation: first layer |u_n| = {first_layer}"
        );
        assert!(r < 0.1, "continuation: RMS |u| = {r}");
        let (x, _, u) = one_projection::<D>(dx, 0.01, WallCondition::Reflection, Init::Stream);
        let first_layer = side_wall_normal_velocity::<D>(dx, &x, &u);
        assert!(
            first_layer > 0.4,
            "reflection: first layer |u_n| = {first_layer}"
        );
    }

    /// `u* = gΔt` everywhere: Continuation's Neumann data is `g` itself, the pressure `ρ g·x` is
    /// linear and its corrected gradient exact, so the fluid stays at rest (measured RMS |u| < 5e-4
    /// gΔt). Reflection lets it fall at 0.91 gΔt (2D) and 0.88 gΔt (3D) RMS in one step (dx = 0.1).
    fn fluid_at_rest_under_gravity_stays_at_rest<D>() {
        let (dx, dt) = (0.1, 0.01);
        let g_dt = 9.81 * dt;
        let (_, _, u) = one_projection::<D>(dx, dt, WallCondition::Continuation, Init::Rest);
        let r = rms::<D>(&u);
        assert!(r < 1e-3 * g_dt, "continuation: RMS |u| = {r}");
        let (_, _, u) = one_projection::<D>(dx, dt, WallCondition::Reflection, Init::Rest);
        let r = rms::<D>(&u);
        assert!(r > 0.5 * g_dt, "reflection: RMS |u| = {r}");
    }

    /// The Taylor–Green cell `(sin πx cos πy, −cos πx sin πy, 0)` is divergence-free with zero normal
    /// velocity on the box: one projection must leave it as it is. Measured RMS change, 2D at
    /// dx = 0.05 / 0.025 and 3D at 0.1 / 0.0625: Continuation 0.013 / 0.0046 and 0.035 / 0.018 (the
    /// Shepard continuation of u into the wall is first order); Reflection 0.0012 / 0.0007 and
    /// 0.0008 / 0.0011.
    fn tangential_divergence_free_flow_passes_the_walls<D>() {
        let (coarse, fine) = if D::DIM == 2 {
            (0.05, 0.025)
        } else {
            (0.1, 0.0625)
        };
        let change = |dx: f64, c| {
            let (_, u0, u) = one_projection::<D>(dx, 0.2 * dx, c, Init::TaylorGreen);
            rms_difference::<D>(&u, &u0)
        };
        let (c0, c1) = (
            change(coarse, WallCondition::Continuation),
            change(fine, WallCondition::Continuation),
        );
        assert!(c1 < 0.02, "continuation at dx = {fine}: {c1}");
        assert!(
            c1 < 0.6 * c0,
            "continuation does not converge: {c0} -> {c1}"
        );
        for dx in [coarse, fine] {
            let r = change(dx, WallCondition::Reflection);
            assert!(r < 0.002, "reflection at dx = {dx}: {r}");
        }
    }
}
