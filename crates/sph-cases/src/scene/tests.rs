use super::*;

const GOOD: &str = r#"
case = "elliptical_drop"
dim = 2
dx = 0.025
dt = 2e-4
t_end = 0.003
schemes = ["euler", "dg"]
[free_surface]
div_r_threshold = 1.5
"#;

#[test]
fn parses_with_defaults() {
    let s = Scene::parse("t", GOOD).unwrap();
    assert_eq!(s.h_over_dx, 1.3);
    assert_eq!(s.kernel, KernelKind::QuinticSpline);
    assert_eq!(s.schemes, vec![SchemeKind::Euler, SchemeKind::Dg]);
    assert_eq!(s.quick(), s);
}

#[test]
fn unknown_key_is_an_error_naming_it() {
    let e = Scene::parse("t", &format!("{GOOD}\nviscosity = 1.0"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("viscosity"), "{e}");
    let e = Scene::parse("t", &GOOD.replace("div_r_threshold", "threshold"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("threshold"), "{e}");
    let e = Scene::parse("t", &GOOD.replace("\"dg\"", "\"dgx\""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("dgx"), "{e}");
}

#[test]
fn bad_values_name_the_key() {
    for (from, to, key) in [
        ("dx = 0.025", "dx = -0.025", "`dx`"),
        ("dt = 2e-4", "dt = 0.0", "`dt`"),
        ("dim = 2", "dim = 3", "`dim`"),
        (
            "div_r_threshold = 1.5",
            "div_r_threshold = 2.5",
            "div_r_threshold",
        ),
        ("schemes = [\"euler\", \"dg\"]", "schemes = []", "`schemes`"),
    ] {
        let e = Scene::parse("scene.toml", &GOOD.replace(from, to))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key) && e.contains("scene.toml"), "{from} -> {e}");
    }
    let e = Scene::parse("t", "case = \"elliptical_drop\"\ndim = ")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line"), "{e}");
}

const CAVITY: &str = r#"
case = "lid_driven_cavity"
dim = 2
dx = 0.05
dt = 0.01
t_end = 1.0
schemes = ["dg"]
[cavity]
reynolds = 100
[effects]
shifting = { coefficient = 2.0 }
"#;

#[test]
fn cavity_scene_declares_its_effects() {
    let s = Scene::parse("c", CAVITY).unwrap();
    let c = s.sim_config();
    assert!(c.effects.shifting.is_some() && c.effects.gravity.is_none());
    // Viscosity comes from the Reynolds number (added by the case), not from the scene.
    assert!(c.effects.viscosity.is_none());
    assert!(Scene::parse("d", GOOD).unwrap().sim_config().effects == Default::default());
    assert!(Scene::parse("c", &CAVITY.replace("dim = 2", "dim = 3")).is_ok());
}

#[test]
fn bad_cavity_values_name_the_key() {
    for (from, to, key) in [
        ("reynolds = 100", "reynolds = -1", "cavity.reynolds"),
        ("dx = 0.05", "dx = 0.03", "`dx`"),
        (
            "coefficient = 2.0",
            "coefficient = 0.0",
            "effects.shifting.coefficient",
        ),
        (
            "[cavity]",
            "[free_surface]\ndiv_r_threshold = 1.5\n[cavity]",
            "free_surface",
        ),
        (
            "[effects]",
            "[effects]\nviscosity = { nu = 0.01 }",
            "effects.viscosity",
        ),
        ("dim = 2", "dim = 4", "`dim`"),
        (
            "reynolds = 100",
            "reynolds = 100\nwall_model = \"ghost\"\nwall_condition = \"reflection\"",
            "cavity.wall_model",
        ),
        (
            "reynolds = 100",
            "reynolds = 100\nwall_model = \"mirror\"",
            "wall_model",
        ),
    ] {
        let e = Scene::parse("cav.toml", &CAVITY.replace(from, to))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{from} -> {e}");
    }
    // Ghost walls with gravity (they would let a fluid at rest fall).
    let ghost = CAVITY.replace("reynolds = 100", "reynolds = 100\nwall_model = \"ghost\"");
    assert!(Scene::parse("c", &ghost).is_ok());
    let e = Scene::parse(
        "c",
        &ghost.replace(
            "shifting = { coefficient = 2.0 }",
            "shifting = { coefficient = 2.0 }\ngravity = [0.0, -9.81, 0.0]",
        ),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("cavity.wall_model") && e.contains("gravity"),
        "{e}"
    );
    let e = Scene::parse("c", &CAVITY.replace("[cavity]\nreynolds = 100\n", ""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("cavity"), "{e}");
    let e = Scene::parse("c", &format!("{CAVITY}\nlid = 2"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("lid"), "{e}");
    let e = Scene::parse("d", &format!("{GOOD}\n[cavity]\nreynolds = 1"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("only valid"), "{e}");
}

/// A flow scene: a water column in an open tank, walls and a free surface together.
pub(crate) const TANK: &str = r#"
dim = 2
dx = 0.05
kernel = "wendland_c2"
dt = 1e-3
t_end = 0.01
schemes = ["dg"]
[[fluid]]
shape = "box"
min = [0.0, 0.0]
max = [0.5, 1.0]
hydrostatic = true
[[wall]]
min = [0.0, 0.0]
max = [2.0, 1.5]
open = ["+y"]
[free_surface]
div_r_threshold = 1.5
[effects]
gravity = [0.0, -9.81, 0.0]
"#;

#[test]
fn flow_scenes_parse_and_bad_blocks_name_the_key() {
    let s = Scene::parse("tank", TANK).unwrap();
    assert_eq!(s.case, CaseKind::Flow);
    assert_eq!(s.fluid.len(), 1);
    for (from, to, key) in [
        ("max = [0.5, 1.0]", "max = [0.5]", "fluid[0].max"),
        ("max = [0.5, 1.0]", "max = [0.53, 1.0]", "fluid[0].max"),
        ("open = [\"+y\"]", "open = [\"top\"]", "wall[0].open"),
        ("open = [\"+y\"]", "open = [\"+z\"]", "wall[0].open"),
        ("shape = \"box\"", "shape = \"circle\"", "fluid[0].center"),
        (
            "hydrostatic = true",
            "hydrostatic = true\nradius = 1.0",
            "fluid[0].radius",
        ),
        ("gravity = [0.0, -9.81, 0.0]", "", "fluid[0].hydrostatic"),
    ] {
        let e = Scene::parse("tank.toml", &TANK.replace(from, to))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{from} -> {to}: {e}");
    }
    // Blocks belong to flow scenes only.
    let e = Scene::parse(
        "d",
        &format!("{GOOD}\n[[wall]]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("`wall`"), "{e}");
}

#[test]
fn periodic_domains_are_checked() {
    let tg = r#"
dim = 2
dx = 0.05
kernel = "wendland_c2"
dt = 1e-3
t_end = 0.01
schemes = ["dg"]
[domain]
min = [0.0, 0.0]
max = [1.0, 1.0]
periodic = ["x", "y"]
[[fluid]]
shape = "box"
min = [0.0, 0.0]
max = [1.0, 1.0]
velocity_field = { kind = "taylor_green" }
"#;
    let s = Scene::parse("tg", tg).unwrap();
    let p = s.periodic_axes().unwrap();
    assert_eq!(p.axes, [true, true, false]);
    for (from, to, key) in [
        (
            "periodic = [\"x\", \"y\"]",
            "periodic = [\"w\"]",
            "domain.periodic",
        ),
        (
            "max = [1.0, 1.0]\nperiodic",
            "max = [0.1, 1.0]\nperiodic",
            "domain.max",
        ),
        (
            "max = [1.0, 1.0]\nperiodic",
            "max = [1.01, 1.0]\nperiodic",
            "domain.max",
        ),
    ] {
        let e = Scene::parse("tg.toml", &tg.replacen(from, to, 1))
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{from} -> {to}: {e}");
    }
    // A closed wall across a periodic axis is refused.
    let e = Scene::parse(
        "tg.toml",
        &format!("{tg}\n[[wall]]\nmin = [0.0, 0.0]\nmax = [1.0, 0.5]\nopen = [\"+y\"]"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("wall[0].open"), "{e}");
}

#[test]
fn allocation_is_bounded_before_allocating() {
    for (text, key) in [
        (CAVITY.replace("dx = 0.05", "dx = 1e-4"), "`dx`"),
        (CAVITY.replace("dx = 0.05", "dx = 1e-7"), "`dx`"),
        (GOOD.replace("dx = 0.025", "dx = 1e-5"), "`dx`"),
        (CAVITY.replace("dt = 0.01", "dt = 1e-12"), "`t_end`"),
        (
            CAVITY.replace("reynolds = 100", "reynolds = 100\nprobe_spacing = 1e-6"),
            "`dx`",
        ),
        (format!("{CAVITY}\n[quick]\ndt = 1e-12"), "`t_end`"),
        (format!("{CAVITY}\n[quick]\ndx = 0.03"), "`dx`"),
    ] {
        let e = Scene::parse("big.toml", &text).unwrap_err().to_string();
        assert!(e.contains(key), "{e}");
    }
    let e = Scene::parse("big.toml", &CAVITY.replace("dx = 0.05", "dx = 1e-4"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("particles") && e.contains("max_particles"),
        "{e}"
    );
    // Raising the limit is the scene's choice.
    let raised = format!(
        "{}\n[limits]\nmax_particles = 3000000\nmax_memory_gb = 64\n",
        CAVITY.replace("dx = 0.05", "dx = 0.001")
    );
    assert!(Scene::parse("big.toml", &raised).is_ok());
}

#[test]
fn resume_differences_name_the_physics_keys() {
    let s = Scene::parse("c", CAVITY).unwrap();
    let mut later = s.clone();
    later.t_end = 40.0;
    later.schemes = vec![SchemeKind::Euler];
    later.cavity.as_mut().unwrap().snapshots = vec![5.0];
    later.solver_tolerance = Some(1e-6);
    assert!(later.resume_differences(&s).is_empty());
    let mut finer = s.clone();
    finer.dx = 0.025;
    assert_eq!(finer.resume_differences(&s), vec!["dx".to_string()]);
    let mut other = s.clone();
    other.cavity.as_mut().unwrap().wall_condition = WallCondition::Reflection;
    assert_eq!(other.resume_differences(&s), vec!["cavity".to_string()]);
}

#[test]
fn viscous_operator_defaults_to_corrected_in_flow_scenes_and_morris_in_the_papers() {
    let op = |text: &str| {
        Scene::parse("s", text)
            .unwrap()
            .sim_config()
            .effects
            .viscosity
            .map(|v| v.operator)
    };
    let viscous = |text: &str, spec: &str| {
        text.replace("[effects]", &format!("[effects]\nviscosity = {{ {spec} }}"))
    };
    let flow = viscous(TANK, "nu = 0.01");
    assert_eq!(op(&flow), Some(ViscousOperator::Corrected));
    assert_eq!(
        op(&viscous(TANK, "nu = 0.01, operator = \"morris\"")),
        Some(ViscousOperator::Morris)
    );
    let paper = format!("{GOOD}\n[effects]\nviscosity = {{ nu = 0.01 }}");
    assert_eq!(op(&paper), Some(ViscousOperator::Morris));
    let chosen =
        format!("{GOOD}\n[effects]\nviscosity = {{ nu = 0.01, operator = \"corrected\" }}");
    assert_eq!(op(&chosen), Some(ViscousOperator::Corrected));
    // An unknown operator is an error naming the key's value.
    let e = Scene::parse("s", &viscous(TANK, "nu = 0.01, operator = \"cubic\""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("cubic") && e.contains("corrected"), "{e}");
}

#[test]
fn density_relaxation_defaults_by_case_and_is_checked() {
    use sph_integrators::DensityRelaxationForm::{Position, Velocity};
    let config = |text: &str| Scene::parse("tank.toml", text).map(|s| s.sim_config());
    // Flow scenes relax by displacements; the paper's cases not at all.
    let c = config(TANK).unwrap();
    assert_eq!(c.density_relaxation, crate::scene::FLOW_DENSITY_RELAXATION);
    assert_eq!(c.density_relaxation_form, Position);
    assert_eq!(config(CAVITY).unwrap().density_relaxation, 0.0);
    let with = |a: &str| {
        TANK.replace(
            "[effects]",
            &format!("[pressure]\ndensity_relaxation = {a}\n[effects]"),
        )
    };
    let c = config(&with("0.1")).unwrap();
    assert_eq!(
        (c.density_relaxation, c.density_relaxation_form),
        (0.1, Position)
    );
    assert_eq!(config(&with("0")).unwrap().density_relaxation, 0.0);
    for bad in ["-0.1", "1.5", "nan"] {
        let e = config(&with(bad)).unwrap_err().to_string();
        assert!(e.contains("pressure.density_relaxation"), "{bad}: {e}");
    }
    let c = config(&with("0.05\ndensity_relaxation_form = \"velocity\"")).unwrap();
    assert_eq!(c.density_relaxation_form, Velocity);
    // A form with the relaxation off, and an unknown form, name the key.
    let e = config(&with("0\ndensity_relaxation_form = \"position\"")).unwrap_err();
    assert!(
        e.to_string().contains("pressure.density_relaxation_form"),
        "{e}"
    );
    let e = config(&with("0.05\ndensity_relaxation_form = \"pressure\"")).unwrap_err();
    assert!(e.to_string().contains("density_relaxation_form"), "{e}");
}

#[test]
fn flow_scenes_operators_follow_their_boundary() {
    use sph_integrators::ShiftScale;
    use sph_operators::GradientForm;
    let shifting = "[effects]\ngravity = [0.0, -9.81, 0.0]\nshifting = { coefficient = 2.0 }";
    let open = TANK.replace("[effects]\ngravity = [0.0, -9.81, 0.0]", shifting);
    let sealed = open.replace(
        "open = [\"+y\"]\n[free_surface]\ndiv_r_threshold = 1.5\n",
        "",
    );
    assert_ne!(open, sealed);
    let config = |text: &str| Scene::parse("tank.toml", text).unwrap().sim_config();
    let scale = |c: &SimConfig| c.effects.shifting.map(|s| s.scale);
    // With a free surface: the symmetric pair with its level term, the shift scaled locally
    // and by the largest speed where the fluid is in tension.
    let c = config(&open);
    assert_eq!(
        (c.gradient, c.renormalise),
        (GradientForm::Symmetric, false)
    );
    assert!(c.level_consistent && c.normalised_gradient);
    assert_eq!(scale(&c), Some(ShiftScale::Tension));
    // Without one: the renormalised difference pair, which no pressure level changes, and δ⁺.
    let c = config(&sealed);
    assert!(c.free_surface.is_none());
    assert_eq!(
        (c.gradient, c.renormalise),
        (GradientForm::Difference, true)
    );
    assert!(!c.level_consistent && !c.normalised_gradient);
    assert_eq!(scale(&c), Some(ShiftScale::Max));
    // A key still overrides each choice; a symmetric gradient chosen for a closed flow is not
    // renormalised (its default pairing).
    let chosen = sealed.replace(
        "[effects]",
        "[pressure]\ngradient = \"symmetric\"\n[effects]",
    );
    let c = config(&chosen.replace(
        "coefficient = 2.0",
        "coefficient = 2.0, velocity = \"local\"",
    ));
    assert_eq!(
        (c.gradient, c.renormalise),
        (GradientForm::Symmetric, false)
    );
    assert!(c.level_consistent);
    assert_eq!(scale(&c), Some(ShiftScale::Local));
    // The tension scale reads the pressure's sign: a closed flow, whose level is arbitrary,
    // may not choose it.
    let tension = sealed.replace(
        "coefficient = 2.0",
        "coefficient = 2.0, velocity = \"tension\"",
    );
    assert_ne!(tension, sealed);
    let err = Scene::parse("tank.toml", &tension).unwrap_err().to_string();
    assert!(
        err.contains("effects.shifting.velocity") && err.contains("free_surface"),
        "{err}"
    );
    let c = config(&open.replace(
        "coefficient = 2.0",
        "coefficient = 2.0, velocity = \"tension\"",
    ));
    assert_eq!(scale(&c), Some(ShiftScale::Tension));
    // The paper's cases keep the paper's operators and local scaling.
    let c = config(&format!(
        "{GOOD}\n[effects]\nshifting = {{ coefficient = 2.0 }}"
    ));
    assert_eq!(
        (c.gradient, c.renormalise),
        (GradientForm::Difference, true)
    );
    assert_eq!(scale(&c), Some(ShiftScale::Local));
}

/// The Robin rows' measured depth: on by default where the rows are Robin rows (a flow
/// scene's free surface), off for the paper's Dirichlet rows; a scene may turn it off, and
/// turning it on without Robin rows is an error naming the key.
#[test]
fn measured_depth_follows_the_robin_rows() {
    let config = |text: &str| Scene::parse("tank.toml", text).unwrap().sim_config();
    let f = config(TANK).free_surface.unwrap();
    assert!(f.zero_pressure_depth > 0.0 && f.measured_depth);
    let off = TANK.replace(
        "[free_surface]\n",
        "[free_surface]\nmeasured_depth = false\n",
    );
    assert_ne!(off, TANK);
    let f = config(&off).free_surface.unwrap();
    assert!(f.zero_pressure_depth > 0.0 && !f.measured_depth);
    let dirichlet = TANK.replace("[free_surface]\n", "[free_surface]\nextrapolate = false\n");
    let f = config(&dirichlet).free_surface.unwrap();
    assert!(f.zero_pressure_depth == 0.0 && !f.measured_depth);
    let bad = dirichlet.replace(
        "extrapolate = false\n",
        "extrapolate = false\nmeasured_depth = true\n",
    );
    let err = Scene::parse("tank.toml", &bad).unwrap_err().to_string();
    assert!(
        err.contains("free_surface.measured_depth") && err.contains("extrapolate"),
        "{err}"
    );
}

/// The speed scale `√(|g| H + U₀²)` from the blocks, and the flow scenes' default
/// hyperviscosity that it scales: with a free surface only, declared values kept, `speed = 0`
/// none.
#[test]
fn speed_scale_and_the_default_hyperviscosity() {
    let tank = Scene::parse("tank", TANK).unwrap();
    let g = 9.81f64;
    assert!(
        (tank.speed_scale() - g.sqrt()).abs() < 1e-12,
        "{}",
        tank.speed_scale()
    );
    let hv = tank.hyperviscosity().unwrap();
    assert_eq!(hv.region, HyperviscousRegion::PositivePressure);
    assert!(
        (hv.speed - FLOW_HYPERVISCOSITY * g.sqrt()).abs() < 1e-12,
        "{hv:?}"
    );
    assert_eq!(tank.sim_config().effects.hyperviscosity, Some(hv));
    // The speed scale of TANK with `from` replaced by `to`, against `want` within `tol`.
    let scale_is = |from: &str, to: &str, want: f64, tol: f64| {
        let s = Scene::parse("variant", &TANK.replace(from, to)).unwrap();
        let got = s.speed_scale();
        assert!((got - want).abs() < tol, "{to}: {got} against {want}");
    };
    // A second block 0.5 higher: the fall to the pool counts.
    let circle = "[[fluid]]\nshape = \"circle\"\ncenter = [1.0, 1.3]\nradius = 0.2\n[[wall]]";
    scale_is("[[wall]]", circle, (g * 1.5).sqrt(), 1e-12);
    // Rotation about the block's centre: ω times the farthest corner; gravity along -y only.
    let corner = (0.25f64.powi(2) + 0.5f64.powi(2)).sqrt();
    let spin = "velocity_field = { kind = \"rigid_rotation\", omega = 2.0 }";
    scale_is(
        "hydrostatic = true",
        spin,
        (g + (2.0 * corner).powi(2)).sqrt(),
        1e-12,
    );
    // A velocity gradient: its largest |G (x − c)| over the box, at a corner.
    let strain = "velocity_gradient = [[-100.0, 0.0], [0.0, 100.0]]";
    let want = (g + 25.0f64.powi(2) + 50.0f64.powi(2)).sqrt();
    scale_is("hydrostatic = true", strain, want, 1e-9);
    // Declared: kept as written; `speed = 0`: none.
    let declared = TANK.replace(
        "gravity = [0.0, -9.81, 0.0]",
        "gravity = [0.0, -9.81, 0.0]\nhyperviscosity = { speed = 0.5 }",
    );
    let hv = Scene::parse("d", &declared)
        .unwrap()
        .hyperviscosity()
        .unwrap();
    assert_eq!((hv.speed, hv.region), (0.5, HyperviscousRegion::Everywhere));
    let off = declared.replace("speed = 0.5", "speed = 0.0");
    assert_eq!(Scene::parse("off", &off).unwrap().hyperviscosity(), None);
    // No free surface, or one of the paper's cases: none.
    let sealed = TANK.replace("[free_surface]\ndiv_r_threshold = 1.5\n", "");
    assert_eq!(
        Scene::parse("sealed", &sealed).unwrap().hyperviscosity(),
        None
    );
    assert_eq!(Scene::parse("d", GOOD).unwrap().hyperviscosity(), None);
}
