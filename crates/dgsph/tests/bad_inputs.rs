//! Bad input never panics, aborts or hangs: ≥ 150 malformed scenes, out-of-range values,
//! bad flags, damaged checkpoints and faulty runs through the `dgsph` binary, each ending with
//! exit code 2 (bad input), 3 (a failed run) or 1 (a failed check) and a message naming what is
//! wrong, within a time limit. Run with `--nocapture` for the table.

mod common;
use common::*;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const DROP: &str = "case = \"elliptical_drop\"\ndim = 2\ndx = 0.1\ndt = 2e-4\nt_end = 6e-4\nschemes = [\"euler\", \"predictor_corrector\", \"dg\"]\n[free_surface]\ndiv_r_threshold = 1.5\n";
const CAVITY: &str = "case = \"lid_driven_cavity\"\ndim = 2\ndx = 0.1\nkernel = \"wendland_c2\"\ndt = 0.01\nt_end = 0.05\nschemes = [\"dg\"]\n[cavity]\nreynolds = 100\ncheck_ghia = false\nprobe_spacing = 0.1\nsnapshots = [0.02]\nsample_every = 1\n[effects]\nshifting = { coefficient = 2.0 }\n[output]\nframe_every = 1\n[limits]\nmax_steps = 1000\n";
const TANK: &str = "dim = 2\ndx = 0.05\nkernel = \"wendland_c2\"\ndt = 1e-3\nt_end = 0.005\nschemes = [\"dg\"]\n[[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]\nhydrostatic = true\nvelocity = [0.0, 0.0]\n[[wall]]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\nopen = [\"+y\"]\nlayers = 3\n[free_surface]\ndiv_r_threshold = 1.5\n[effects]\ngravity = [0.0, -9.81, 0.0]\n[output]\nsample_every = 1\n[[check]]\nquantity = \"max_wall_penetrations\"\nmax = 0\n";
const TG: &str = "dim = 2\ndx = 0.05\nkernel = \"wendland_c2\"\ndt = 1e-3\nt_end = 0.005\nschemes = [\"dg\"]\n[domain]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\nperiodic = [\"x\", \"y\"]\n[[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\nvelocity_field = { kind = \"taylor_green\" }\n";

/// One bad input: a scene text (or none), extra arguments, the exit codes allowed and a phrase
/// the message must contain.
struct Case {
    name: String,
    scene: Option<String>,
    args: Vec<String>,
    codes: &'static [i32],
    expect: &'static str,
}

fn scene_case(name: &str, base: &str, from: &str, to: &str, expect: &'static str) -> Case {
    assert!(
        base.contains(from),
        "{name}: {from:?} not in the base scene"
    );
    Case {
        name: name.to_string(),
        scene: Some(base.replacen(from, to, 1)),
        args: vec!["check".into()],
        codes: &[2],
        expect,
    }
}

fn cases() -> Vec<Case> {
    let mut c = Vec::new();
    // Malformed TOML and wrong types.
    for (i, text) in [
        "",
        "\u{0}\u{1}\u{2}",
        "case = \"elliptical_drop\"\ndim = ",
        "[[fluid]\nshape = \"box\"",
        "dim = 2\ndim = 3",
        "dim = \"two\"",
        "dx = [0.1]",
        "schemes = \"dg\"",
        "[free_surface]\n[free_surface]",
        "dim = 2\n\u{feff}dx = ?",
        &"x".repeat(100_000),
        "case = 5",
    ]
    .iter()
    .enumerate()
    {
        c.push(Case {
            name: format!("malformed {i}"),
            scene: Some(text.to_string()),
            args: vec!["check".into()],
            codes: &[2],
            expect: "",
        });
    }
    // Unknown keys, one per table.
    for (base, anchor, table) in [
        (DROP, "t_end = 6e-4\n", "top level"),
        (DROP, "div_r_threshold = 1.5\n", "free_surface"),
        (CAVITY, "reynolds = 100\n", "cavity"),
        (CAVITY, "shifting = { coefficient = 2.0 }\n", "effects"),
        (CAVITY, "frame_every = 1\n", "output"),
        (CAVITY, "max_steps = 1000\n", "limits"),
        (TANK, "hydrostatic = true\n", "fluid"),
        (TANK, "layers = 3\n", "wall"),
        (TANK, "max = 0\n", "check"),
        (TG, "periodic = [\"x\", \"y\"]\n", "domain"),
    ] {
        c.push(scene_case(
            &format!("unknown key in {table}"),
            base,
            anchor,
            &format!("{anchor}bogus_key = 1\n"),
            "bogus_key",
        ));
    }
    // Out-of-range and inconsistent values, each naming its key.
    let values: &[(&str, &str, &str, &str, &'static str)] = &[
        ("dim 0", DROP, "dim = 2", "dim = 0", "dim"),
        ("dim 4", DROP, "dim = 2", "dim = 4", "dim"),
        ("dim 3 for a 2D case", DROP, "dim = 2", "dim = 3", "dim"),
        ("dx 0", DROP, "dx = 0.1", "dx = 0.0", "dx"),
        ("dx negative", DROP, "dx = 0.1", "dx = -0.1", "dx"),
        ("dx nan", DROP, "dx = 0.1", "dx = nan", "dx"),
        ("dx inf", DROP, "dx = 0.1", "dx = inf", "dx"),
        ("dx 2 (one particle)", DROP, "dx = 0.1", "dx = 2.0", "dx"),
        (
            "dx 1e-4 drop (too many particles)",
            DROP,
            "dx = 0.1",
            "dx = 1e-4",
            "dx",
        ),
        ("dx 1e-7 drop", DROP, "dx = 0.1", "dx = 1e-7", "dx"),
        ("dx 1e-4 cavity", CAVITY, "dx = 0.1", "dx = 1e-4", "dx"),
        ("dx 1e-7 cavity", CAVITY, "dx = 0.1", "dx = 1e-7", "dx"),
        ("dx 0.03 cavity", CAVITY, "dx = 0.1", "dx = 0.03", "dx"),
        (
            "h_over_dx 0.5",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nh_over_dx = 0.5\n",
            "h_over_dx",
        ),
        (
            "h_over_dx 5",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nh_over_dx = 5.0\n",
            "h_over_dx",
        ),
        (
            "h_over_dx nan",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nh_over_dx = nan\n",
            "h_over_dx",
        ),
        ("dt 0", DROP, "dt = 2e-4", "dt = 0.0", "dt"),
        ("dt negative", DROP, "dt = 2e-4", "dt = -2e-4", "dt"),
        ("dt inf", DROP, "dt = 2e-4", "dt = inf", "dt"),
        (
            "dt 1e-12 (too many steps)",
            CAVITY,
            "dt = 0.01",
            "dt = 1e-12",
            "t_end",
        ),
        ("t_end 0", DROP, "t_end = 6e-4", "t_end = 0.0", "t_end"),
        (
            "t_end negative",
            DROP,
            "t_end = 6e-4",
            "t_end = -1.0",
            "t_end",
        ),
        ("t_end nan", DROP, "t_end = 6e-4", "t_end = nan", "t_end"),
        (
            "no scheme",
            DROP,
            "schemes = [\"euler\", \"predictor_corrector\", \"dg\"]",
            "schemes = []",
            "schemes",
        ),
        (
            "scheme twice",
            DROP,
            "schemes = [\"euler\", \"predictor_corrector\", \"dg\"]",
            "schemes = [\"dg\", \"dg\"]",
            "schemes",
        ),
        ("unknown scheme", DROP, "\"dg\"]", "\"dgx\"]", "dgx"),
        (
            "unknown kernel",
            CAVITY,
            "kernel = \"wendland_c2\"",
            "kernel = \"gaussian\"",
            "gaussian",
        ),
        (
            "unknown solver",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nsolver = \"cg\"\n",
            "cg",
        ),
        (
            "solver tolerance 0",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nsolver_tolerance = 0.0\n",
            "solver_tolerance",
        ),
        (
            "solver tolerance 1",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nsolver_tolerance = 1.0\n",
            "solver_tolerance",
        ),
        (
            "solver tolerance nan",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nsolver_tolerance = nan\n",
            "solver_tolerance",
        ),
        (
            "rho0 0",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nrho0 = 0.0\n",
            "rho0",
        ),
        (
            "rho0 negative",
            DROP,
            "dx = 0.1\n",
            "dx = 0.1\nrho0 = -1.0\n",
            "rho0",
        ),
        (
            "threshold 0",
            DROP,
            "div_r_threshold = 1.5",
            "div_r_threshold = 0.0",
            "div_r_threshold",
        ),
        (
            "threshold above d",
            DROP,
            "div_r_threshold = 1.5",
            "div_r_threshold = 2.5",
            "div_r_threshold",
        ),
        (
            "threshold negative",
            DROP,
            "div_r_threshold = 1.5",
            "div_r_threshold = -1.0",
            "div_r_threshold",
        ),
        (
            "reynolds 0",
            CAVITY,
            "reynolds = 100",
            "reynolds = 0.0",
            "cavity.reynolds",
        ),
        (
            "reynolds negative",
            CAVITY,
            "reynolds = 100",
            "reynolds = -1.0",
            "cavity.reynolds",
        ),
        (
            "reynolds nan",
            CAVITY,
            "reynolds = 100",
            "reynolds = nan",
            "cavity.reynolds",
        ),
        (
            "reynolds inf",
            CAVITY,
            "reynolds = 100",
            "reynolds = inf",
            "cavity.reynolds",
        ),
        (
            "lid speed 0",
            CAVITY,
            "reynolds = 100\n",
            "reynolds = 100\nlid_speed = 0.0\n",
            "cavity.lid_speed",
        ),
        (
            "wall layers 0",
            CAVITY,
            "reynolds = 100\n",
            "reynolds = 100\nwall_layers = 0\n",
            "cavity.wall_layers",
        ),
        (
            "wall layers 11",
            CAVITY,
            "reynolds = 100\n",
            "reynolds = 100\nwall_layers = 11\n",
            "cavity.wall_layers",
        ),
        (
            "probe spacing 0",
            CAVITY,
            "probe_spacing = 0.1",
            "probe_spacing = 0.0",
            "cavity.probe_spacing",
        ),
        (
            "probe spacing tiny",
            CAVITY,
            "probe_spacing = 0.1",
            "probe_spacing = 1e-9",
            "dx",
        ),
        (
            "probe spacing 0.6",
            CAVITY,
            "probe_spacing = 0.1",
            "probe_spacing = 0.6",
            "cavity.probe_spacing",
        ),
        (
            "negative snapshot",
            CAVITY,
            "snapshots = [0.02]",
            "snapshots = [-1.0]",
            "cavity.snapshots",
        ),
        (
            "sample_every 0",
            CAVITY,
            "sample_every = 1",
            "sample_every = 0",
            "cavity.sample_every",
        ),
        (
            "ghia tolerance negative",
            CAVITY,
            "reynolds = 100\n",
            "reynolds = 100\nghia_tolerance = [-0.1, 0.05]\n",
            "cavity.ghia_tolerance",
        ),
        (
            "cavity with a free surface",
            CAVITY,
            "[cavity]",
            "[free_surface]\n[cavity]",
            "free_surface",
        ),
        (
            "cavity with viscosity",
            CAVITY,
            "[effects]\n",
            "[effects]\nviscosity = { nu = 0.01 }\n",
            "effects.viscosity",
        ),
        (
            "cavity table in a drop",
            DROP,
            "[free_surface]",
            "[cavity]\nreynolds = 1.0\n[free_surface]",
            "only valid",
        ),
        (
            "no cavity table",
            CAVITY,
            "[cavity]\nreynolds = 100\ncheck_ghia = false\nprobe_spacing = 0.1\nsnapshots = [0.02]\nsample_every = 1\n",
            "",
            "cavity",
        ),
        (
            "gravity nan",
            TANK,
            "gravity = [0.0, -9.81, 0.0]",
            "gravity = [0.0, nan, 0.0]",
            "effects.gravity",
        ),
        (
            "viscosity negative",
            TANK,
            "gravity = [0.0, -9.81, 0.0]\n",
            "gravity = [0.0, -9.81, 0.0]\nviscosity = { nu = -1.0 }\n",
            "effects.viscosity.nu",
        ),
        (
            "hyperviscosity negative",
            TANK,
            "gravity = [0.0, -9.81, 0.0]\n",
            "gravity = [0.0, -9.81, 0.0]\nhyperviscosity = { speed = -0.1 }\n",
            "effects.hyperviscosity.speed",
        ),
        (
            "hyperviscosity by pressure, no free surface",
            TG,
            "velocity_field = { kind = \"taylor_green\" }\n",
            "velocity_field = { kind = \"taylor_green\" }\n[effects]\n\
             hyperviscosity = { speed = 0.3, region = \"positive_pressure\" }\n",
            "effects.hyperviscosity.region",
        ),
        (
            "hyperviscosity unknown region",
            TANK,
            "gravity = [0.0, -9.81, 0.0]\n",
            "gravity = [0.0, -9.81, 0.0]\nhyperviscosity = { speed = 0.3, region = \"surface\" }\n",
            "surface",
        ),
        (
            "hyperviscosity unknown key",
            TANK,
            "gravity = [0.0, -9.81, 0.0]\n",
            "gravity = [0.0, -9.81, 0.0]\nhyperviscosity = { nu4 = 1e-6 }\n",
            "nu4",
        ),
        (
            "shifting 0",
            CAVITY,
            "coefficient = 2.0",
            "coefficient = 0.0",
            "effects.shifting.coefficient",
        ),
        (
            "shifting negative",
            CAVITY,
            "coefficient = 2.0",
            "coefficient = -2.0",
            "effects.shifting.coefficient",
        ),
        (
            "box min above max",
            TANK,
            "max = [0.5, 0.5]",
            "max = [-0.5, 0.5]",
            "fluid[0].max",
        ),
        (
            "box corner wrong length",
            TANK,
            "max = [0.5, 0.5]",
            "max = [0.5]",
            "fluid[0].max",
        ),
        (
            "box corner off the lattice",
            TANK,
            "max = [0.5, 0.5]",
            "max = [0.53, 0.5]",
            "fluid[0].max",
        ),
        (
            "box without max",
            TANK,
            "max = [0.5, 0.5]\n",
            "",
            "fluid[0].max",
        ),
        (
            "circle without radius",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
            "shape = \"circle\"\ncenter = [0.5, 0.5]",
            "fluid[0].radius",
        ),
        (
            "circle radius 0",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
            "shape = \"circle\"\ncenter = [0.5, 0.5]\nradius = 0.0",
            "fluid[0].radius",
        ),
        (
            "circle radius negative",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
            "shape = \"circle\"\ncenter = [0.5, 0.5]\nradius = -0.1",
            "fluid[0].radius",
        ),
        (
            "circle with a box corner",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]",
            "shape = \"circle\"\ncenter = [0.5, 0.5]\nradius = 0.2\nmin = [0.0, 0.0]",
            "fluid[0].min",
        ),
        (
            "ellipse negative axis",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
            "shape = \"ellipse\"\ncenter = [0.5, 0.5]\nsemi_axes = [0.2, -0.1]",
            "fluid[0].semi_axes",
        ),
        (
            "ellipse no center",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
            "shape = \"ellipse\"\nsemi_axes = [0.2, 0.1]",
            "fluid[0].center",
        ),
        (
            "polygon of two vertices",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
            "shape = \"polygon\"\nvertices = [[0.1, 0.1], [0.4, 0.4]]",
            "fluid[0].vertices",
        ),
        (
            "polygon without area",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
            "shape = \"polygon\"\nvertices = [[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]]",
            "fluid[0].vertices",
        ),
        (
            "unknown shape",
            TANK,
            "shape = \"box\"\nmin",
            "shape = \"torus\"\nmin",
            "torus",
        ),
        (
            "velocity wrong length",
            TANK,
            "velocity = [0.0, 0.0]",
            "velocity = [0.0, 0.0, 0.0]",
            "fluid[0].velocity",
        ),
        (
            "velocity nan",
            TANK,
            "velocity = [0.0, 0.0]",
            "velocity = [nan, 0.0]",
            "fluid[0].velocity",
        ),
        (
            "gradient wrong shape",
            TANK,
            "velocity = [0.0, 0.0]",
            "velocity_gradient = [[1.0, 0.0]]",
            "fluid[0].velocity_gradient",
        ),
        (
            "rotation without omega",
            TANK,
            "velocity = [0.0, 0.0]",
            "velocity_field = { kind = \"rigid_rotation\" }",
            "omega",
        ),
        (
            "taylor-green wavelength 0",
            TANK,
            "velocity = [0.0, 0.0]",
            "velocity_field = { kind = \"taylor_green\", wavelength = 0.0 }",
            "wavelength",
        ),
        (
            "unknown field",
            TANK,
            "velocity = [0.0, 0.0]",
            "velocity_field = { kind = \"vortex\" }",
            "vortex",
        ),
        (
            "jitter 0.5",
            TANK,
            "hydrostatic = true",
            "hydrostatic = true\njitter = 0.5",
            "fluid[0].jitter",
        ),
        (
            "jitter negative",
            TANK,
            "hydrostatic = true",
            "hydrostatic = true\njitter = -0.1",
            "fluid[0].jitter",
        ),
        (
            "hydrostatic without gravity",
            TANK,
            "gravity = [0.0, -9.81, 0.0]",
            "",
            "fluid[0].hydrostatic",
        ),
        (
            "no fluid block",
            TANK,
            "[[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]\nhydrostatic = true\nvelocity = [0.0, 0.0]\n",
            "",
            "fluid",
        ),
        (
            "fluid block in a cavity",
            CAVITY,
            "[cavity]",
            "[[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]\n[cavity]",
            "fluid",
        ),
        (
            "unknown face",
            TANK,
            "open = [\"+y\"]",
            "open = [\"top\"]",
            "wall[0].open",
        ),
        (
            "3D face in 2D",
            TANK,
            "open = [\"+y\"]",
            "open = [\"+z\"]",
            "wall[0].open",
        ),
        (
            "all faces open",
            TANK,
            "open = [\"+y\"]",
            "open = [\"+y\", \"-y\", \"+x\", \"-x\"]",
            "wall[0].open",
        ),
        (
            "wall layers 0",
            TANK,
            "layers = 3",
            "layers = 0",
            "wall[0].layers",
        ),
        (
            "wall min above max",
            TANK,
            "max = [1.0, 1.0]",
            "max = [1.0, -1.0]",
            "wall[0].max",
        ),
        (
            "wall off the lattice",
            TANK,
            "max = [1.0, 1.0]",
            "max = [1.01, 1.0]",
            "wall[0].max",
        ),
        (
            "face velocity on an open face",
            TANK,
            "layers = 3",
            "layers = 3\nface_velocity = { \"+y\" = [1.0, 0.0] }",
            "wall[0].face_velocity",
        ),
        (
            "face velocity unknown face",
            TANK,
            "layers = 3",
            "layers = 3\nface_velocity = { \"up\" = [1.0, 0.0] }",
            "wall[0].face_velocity",
        ),
        (
            "face velocity wrong length",
            TANK,
            "layers = 3",
            "layers = 3\nface_velocity = { \"-y\" = [1.0] }",
            "face_velocity",
        ),
        (
            "solid with an open face",
            TANK,
            "open = [\"+y\"]",
            "kind = \"solid\"\nopen = [\"+y\"]",
            "wall[0].open",
        ),
        (
            "unknown wall kind",
            TANK,
            "open = [\"+y\"]",
            "kind = \"fence\"\nopen = [\"+y\"]",
            "fence",
        ),
        (
            "wall condition without walls",
            TG,
            "dt = 1e-3",
            "dt = 1e-3\nwall_condition = \"continuation\"",
            "wall_condition",
        ),
        (
            "periodic unknown axis",
            TG,
            "periodic = [\"x\", \"y\"]",
            "periodic = [\"w\"]",
            "domain.periodic",
        ),
        (
            "periodic axis twice",
            TG,
            "periodic = [\"x\", \"y\"]",
            "periodic = [\"x\", \"x\"]",
            "domain.periodic",
        ),
        (
            "periodic z in 2D",
            TG,
            "periodic = [\"x\", \"y\"]",
            "periodic = [\"z\"]",
            "domain.periodic",
        ),
        (
            "period too short",
            TG,
            "max = [1.0, 1.0]\nperiodic",
            "max = [0.2, 1.0]\nperiodic",
            "domain.max",
        ),
        (
            "period off the lattice",
            TG,
            "max = [1.0, 1.0]\nperiodic",
            "max = [1.01, 1.0]\nperiodic",
            "domain.max",
        ),
        (
            "domain without corners",
            TG,
            "min = [0.0, 0.0]\nmax = [1.0, 1.0]\nperiodic",
            "periodic",
            "domain.min",
        ),
        (
            "domain without axes",
            TG,
            "periodic = [\"x\", \"y\"]",
            "periodic = []",
            "domain.periodic",
        ),
        (
            "closed wall across a periodic axis",
            TG,
            "[[fluid]]",
            "[[wall]]\nmin = [0.0, 0.0]\nmax = [1.0, 0.5]\nopen = [\"+y\"]\n[[fluid]]",
            "wall[0].open",
        ),
        ("check without bounds", TANK, "max = 0\n", "", "check[0]"),
        (
            "check unknown quantity",
            TANK,
            "quantity = \"max_wall_penetrations\"",
            "quantity = \"happiness\"",
            "check[0].quantity",
        ),
        (
            "check min above max",
            TANK,
            "max = 0\n",
            "max = 0\nmin = 1\n",
            "check[0]",
        ),
        (
            "check empty quantity",
            TANK,
            "quantity = \"max_wall_penetrations\"",
            "quantity = \"\"",
            "check[0].quantity",
        ),
        (
            "check for a scheme not run",
            TANK,
            "max = 0\n",
            "max = 0\nschemes = [\"euler\"]\n",
            "check[0].schemes",
        ),
        (
            "check bound nan",
            TANK,
            "max = 0\n",
            "max = nan\n",
            "check[0]",
        ),
        (
            "output sample_every 0",
            TANK,
            "sample_every = 1",
            "sample_every = 0",
            "output.sample_every",
        ),
        (
            "output frame_every 0",
            CAVITY,
            "frame_every = 1",
            "frame_every = 0",
            "output.frame_every",
        ),
        (
            "output negative snapshot",
            TANK,
            "sample_every = 1",
            "sample_every = 1\nsnapshots = [-0.5]",
            "output.snapshots",
        ),
        (
            "unknown diagnostic",
            TANK,
            "sample_every = 1",
            "sample_every = 1\ndiagnostics = [\"vorticity\"]",
            "vorticity",
        ),
        (
            "limits max_particles 0",
            CAVITY,
            "max_steps = 1000",
            "max_steps = 1000\nmax_particles = 0",
            "limits.max_particles",
        ),
        (
            "limits max_steps 0",
            CAVITY,
            "max_steps = 1000",
            "max_steps = 0",
            "limits.max_steps",
        ),
        (
            "limits memory negative",
            CAVITY,
            "max_steps = 1000",
            "max_steps = 1000\nmax_memory_gb = -1.0",
            "limits.max_memory_gb",
        ),
        (
            "limits displacement 0",
            CAVITY,
            "max_steps = 1000",
            "max_steps = 1000\nmax_displacement = 0.0",
            "limits.max_displacement",
        ),
        (
            "limits speed ratio negative",
            CAVITY,
            "max_steps = 1000",
            "max_steps = 1000\nmax_speed_ratio = -5.0",
            "limits.max_speed_ratio",
        ),
        (
            "steps above the limit",
            CAVITY,
            "max_steps = 1000",
            "max_steps = 2",
            "t_end",
        ),
        (
            "particles above the limit",
            CAVITY,
            "max_steps = 1000",
            "max_steps = 1000\nmax_particles = 100",
            "dx",
        ),
        (
            "memory above the limit",
            CAVITY,
            "max_steps = 1000",
            "max_steps = 1000\nmax_memory_gb = 1e-6",
            "dx",
        ),
        (
            "quick dx not dividing",
            CAVITY,
            "max_steps = 1000\n",
            "max_steps = 1000\n[quick]\ndx = 0.03\n",
            "dx",
        ),
        (
            "quick dt 1e-12",
            CAVITY,
            "max_steps = 1000\n",
            "max_steps = 1000\n[quick]\ndt = 1e-12\n",
            "t_end",
        ),
        (
            "quick dx negative",
            CAVITY,
            "max_steps = 1000\n",
            "max_steps = 1000\n[quick]\ndx = -1.0\n",
            "quick.dx",
        ),
        (
            "quick check_ghia in a drop",
            DROP,
            "div_r_threshold = 1.5\n",
            "div_r_threshold = 1.5\n[quick]\ncheck_ghia = false\n",
            "quick.check_ghia",
        ),
        (
            "consistent laplacian without renormalisation",
            TANK,
            "[free_surface]",
            "[pressure]\nconsistent_laplacian = true\nrenormalise = false\n[free_surface]",
            "pressure.consistent_laplacian",
        ),
        (
            "adjoint gradient without renormalisation",
            TANK,
            "[free_surface]",
            "[pressure]\ngradient = \"adjoint\"\n[free_surface]",
            "pressure.gradient",
        ),
        (
            "level term with the difference gradient",
            TANK,
            "[free_surface]",
            "[pressure]\ngradient = \"difference\"\nlevel_consistent = true\n[free_surface]",
            "pressure.level_consistent",
        ),
        (
            "normalised gradient with renormalisation",
            TANK,
            "[free_surface]",
            "[pressure]\ngradient = \"difference\"\nrenormalise = true\nnormalise_gradient = true\n[free_surface]",
            "pressure.normalise_gradient",
        ),
        (
            "open face named with a multi-byte character",
            TANK,
            "open = [\"+y\"]",
            "open = [\"é+y\"]",
            "open",
        ),
        (
            "surface pressure extrapolated with the symmetric gradient without its level term",
            TANK,
            "[free_surface]",
            "[pressure]\ngradient = \"symmetric\"\nlevel_consistent = false\n[free_surface]\nextrapolate = true",
            "free_surface.extrapolate",
        ),
        (
            "relax iterations negative",
            TANK,
            "[free_surface]",
            "[start]\nrelax_iterations = -1\n[free_surface]",
            "relax_iterations",
        ),
        (
            "advective coefficient zero",
            TANK,
            "[free_surface]",
            "[time_step]\nadvective = 0.0\n[free_surface]",
            "time_step.advective",
        ),
        (
            "viscous coefficient above one",
            TANK,
            "[free_surface]",
            "[time_step]\nviscous = 1.5\n[free_surface]",
            "time_step.viscous",
        ),
        (
            "viscosity whose automatic step needs 1e8 steps",
            TANK,
            "gravity = [0.0, -9.81, 0.0]\n",
            "gravity = [0.0, -9.81, 0.0]\nviscosity = { nu = 1e7 }\n",
            "viscous limit",
        ),
        (
            "channel without viscosity",
            TANK,
            "[free_surface]",
            "[channel]\nkind = \"couette\"\nheight = 1.0\nwall_speed = 1.0\n[free_surface]",
            "viscosity",
        ),
        (
            "channel of zero height",
            TANK,
            "[free_surface]",
            "[channel]\nkind = \"poiseuille\"\nheight = 0.0\n[free_surface]",
            "channel.height",
        ),
        (
            "unknown channel kind",
            TANK,
            "[free_surface]",
            "[channel]\nkind = \"hagen\"\nheight = 1.0\n[free_surface]",
            "hagen",
        ),
        (
            "unknown time-step key",
            TANK,
            "[free_surface]",
            "[time_step]\ncfl = 0.3\n[free_surface]",
            "cfl",
        ),
        (
            "settle steps negative",
            TANK,
            "[free_surface]",
            "[free_surface]\n[start]\nsettle_steps = -3",
            "settle_steps",
        ),
        (
            "settle damping out of range",
            TANK,
            "[free_surface]",
            "[start]\nsettle_steps = 10\nsettle_damping = 1.5\n[free_surface]",
            "start.settle_damping",
        ),
        (
            "unknown shift correction",
            TANK,
            "gravity = [0.0, -9.81, 0.0]",
            "gravity = [0.0, -9.81, 0.0]\nshifting = { coefficient = 2.0, velocity_correction = \"quadratic\" }",
            "quadratic",
        ),
        (
            "unknown gradient",
            TANK,
            "[free_surface]",
            "[pressure]\ngradient = \"central\"\n[free_surface]",
            "central",
        ),
        (
            "prescribed with dg",
            DROP,
            "case = \"elliptical_drop\"",
            "case = \"prescribed_ellipse\"",
            "schemes",
        ),
        (
            "unknown case",
            DROP,
            "case = \"elliptical_drop\"",
            "case = \"lid_cavity\"",
            "lid_cavity",
        ),
        (
            "dam break with a circle",
            TANK,
            "dim = 2\n",
            "case = \"dam_break\"\ndim = 2\n",
            "",
        ),
        (
            "dam break gravity along x",
            TANK,
            "gravity = [0.0, -9.81, 0.0]",
            "gravity = [-9.81, 0.0, 0.0]",
            "",
        ),
    ];
    for (name, base, from, to, key) in values {
        let mut case = scene_case(name, base, from, to, key);
        if name.starts_with("dam break") {
            // A dam break must be a box column under gravity along −y in a container.
            case.scene = Some(
                base.replacen(from, to, 1)
                    .replace("case = \"dam_break\"\n", "")
                    .replacen("dim = 2\n", "case = \"dam_break\"\ndim = 2\n", 1),
            );
            if *name == "dam break with a circle" {
                case.scene = Some(
                    case.scene
                        .unwrap()
                        .replace(
                            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
                            "shape = \"circle\"\ncenter = [0.5, 0.5]\nradius = 0.2",
                        )
                        .replace("hydrostatic = true\n", ""),
                );
            }
        }
        c.push(case);
    }
    // Bad flags of `dgsph run` (on a valid scene), and a missing or unreadable scene.
    for (name, args, expect) in [
        (
            "checkpoint-every 0",
            vec!["--checkpoint-every", "0"],
            "checkpoint-every",
        ),
        ("frame-every 0", vec!["--frame-every", "0"], "frame-every"),
        (
            "sample-every 0",
            vec!["--sample-every", "0"],
            "sample-every",
        ),
        (
            "tag escaping the output directory",
            vec!["--tag", "../../x"],
            "output name",
        ),
        ("tag hidden", vec!["--tag", ".hidden"], "output name"),
        ("tag empty", vec!["--tag", ""], "output name"),
        ("tag with a slash", vec!["--tag", "a/b"], "output name"),
        (
            "resume without a checkpoint",
            vec!["--resume"],
            "no checkpoint",
        ),
        ("unknown preset", vec!["--preset", "fast"], "fast"),
        ("dt override negative", vec!["--dt", "-1"], "dt"),
        ("dx override 0", vec!["--dx", "0"], "dx"),
        ("t-end override nan", vec!["--t-end", "NaN"], "t_end"),
        ("unknown scheme override", vec!["--schemes", "rk4"], "rk4"),
        (
            "unknown kernel override",
            vec!["--kernel", "gauss"],
            "gauss",
        ),
        (
            "unknown solver override",
            vec!["--solver", "gmres"],
            "gmres",
        ),
        ("re on a drop", vec!["--re", "100"], "--re"),
        (
            "negative progress interval",
            vec!["--progress-every", "-1"],
            "progress-every",
        ),
        ("unknown flag", vec!["--fast"], "--fast"),
        (
            "shifting override negative",
            vec!["--shifting", "-2"],
            "shifting",
        ),
        (
            "threshold override 5",
            vec!["--div-r-threshold", "5"],
            "div_r_threshold",
        ),
        (
            "unknown Hessian override",
            vec!["--dg-hessian", "exact"],
            "exact",
        ),
    ] {
        c.push(Case {
            name: format!("flag: {name}"),
            scene: Some(DROP.to_string()),
            args: ["run".to_string()]
                .into_iter()
                .chain(args.into_iter().map(String::from))
                .collect(),
            codes: &[2],
            expect,
        });
    }
    c.push(Case {
        name: "missing scene file".into(),
        scene: None,
        args: vec!["check".into(), "/nonexistent/scene.toml".into()],
        codes: &[2],
        expect: "reading scene",
    });
    c.push(Case {
        name: "scene is a directory".into(),
        scene: None,
        args: vec!["check".into(), "/tmp".into()],
        codes: &[2],
        expect: "reading scene",
    });
    c.push(Case {
        name: "report of a missing directory".into(),
        scene: None,
        args: vec!["report".into(), "/nonexistent/out".into()],
        codes: &[2],
        expect: "reading",
    });
    // Faulty runs: blow-ups and a solver that cannot converge end as failed runs (3).
    for (name, base, from, to, expect) in [
        (
            "cavity with 100x the time step",
            CAVITY,
            "dt = 0.01\nt_end = 0.05",
            "dt = 1.0\nt_end = 5.0",
            "blow-up",
        ),
        // ν = 1e30: the explicit viscous step leaves `Δt ∇u*` of order 1e29 beside the lid
        // (Δt ν U / dx² = 1e30 in u*), and a DG row's diagonal is a sum of such terms that
        // should nearly cancel. Rounding decides which of the solve's checks stops it — a row
        // whose diagonal came out exactly zero, or 2 000 iterations without converging (the
        // relative residual 7e24); either is the typed pressure-solve error.
        (
            "cavity with Re 1e-30",
            CAVITY,
            "reynolds = 100",
            "reynolds = 1e-30",
            "pressure solve failed",
        ),
        (
            "tank with viscosity 1e6 at a fixed step",
            TANK,
            "gravity = [0.0, -9.81, 0.0]\n",
            "gravity = [0.0, -9.81, 0.0]\nviscosity = { nu = 1e6 }\n[time_step]\nauto = false\n",
            "blow-up",
        ),
        (
            "drop with 100x the time step",
            DROP,
            "dt = 2e-4\nt_end = 6e-4",
            "dt = 2e-2\nt_end = 0.06",
            "blow-up",
        ),
        (
            "prescribed field with a huge time step",
            DROP,
            "case = \"elliptical_drop\"\ndim = 2\ndx = 0.1\ndt = 2e-4\nt_end = 6e-4\nschemes = [\"euler\", \"predictor_corrector\", \"dg\"]",
            "case = \"prescribed_ellipse\"\ndim = 2\ndx = 0.1\ndt = 20.0\nt_end = 2000.0\nschemes = [\"euler\"]",
            "blow-up",
        ),
        (
            "solver tolerance 1e-16",
            CAVITY,
            "t_end = 0.05\n",
            "t_end = 0.05\nsolver_tolerance = 1e-16\n",
            "did not converge",
        ),
        // A fixed step: the flow scenes' automatic step would shrink it to a stable one.
        (
            "taylor-green at 100x the time step under pc",
            TG,
            "dt = 1e-3\nt_end = 0.005\nschemes = [\"dg\"]",
            "dt = 0.1\nt_end = 0.5\nschemes = [\"predictor_corrector\"]\n[time_step]\nauto = false",
            "blow-up",
        ),
        (
            "displacement limit tiny",
            TANK,
            "[output]",
            "[limits]\nmax_displacement = 1e-9\n[output]",
            "blow-up",
        ),
        (
            "speed limit under the flow's own speed",
            TG,
            "velocity_field = { kind = \"taylor_green\" }\n",
            "velocity_field = { kind = \"taylor_green\" }\n[limits]\nmax_speed_ratio = 0.5\n",
            "max_speed_ratio",
        ),
    ] {
        let mut case = scene_case(name, base, from, to, expect);
        case.args = vec!["run".into()];
        case.codes = &[3];
        c.push(case);
    }
    // Issue 48's inputs that got through: sizes that underflow, a run of no step, blocks that
    // never meet their walls or overflow their periodic box, a 3D vertex in 2D, a snapshot
    // never reached, a flag that does not apply.
    for (name, base, from, to, expect) in [
        (
            "dx 5e-324",
            TANK,
            "dx = 0.05",
            "dx = 5e-324",
            "too small to count",
        ),
        (
            "dx 1e-300",
            TANK,
            "dx = 0.05",
            "dx = 1e-300",
            "too small to count",
        ),
        ("cavity dx 1e-300", CAVITY, "dx = 0.1", "dx = 1e-300", "dx"),
        (
            "dt 1e9 t_end",
            TANK,
            "dt = 1e-3",
            "dt = 5e6",
            "no full step",
        ),
        (
            "dt just over t_end",
            TANK,
            "dt = 1e-3",
            "dt = 0.006",
            "no full step",
        ),
        (
            "fluid beside its container",
            TANK,
            "min = [0.0, 0.0]
max = [0.5, 0.5]
hydrostatic",
            "min = [3.0, 0.0]
max = [3.5, 0.5]
hydrostatic",
            "outside every container",
        ),
        (
            "fluid below its container",
            TANK,
            "min = [0.0, 0.0]
max = [0.5, 0.5]
hydrostatic",
            "min = [0.0, -2.0]
max = [0.5, -1.5]
hydrostatic",
            "outside every container",
        ),
        (
            "fluid larger than its periodic box",
            TG,
            "min = [0.0, 0.0]
max = [1.0, 1.0]
velocity_field",
            "min = [0.0, 0.0]
max = [2.0, 1.0]
velocity_field",
            "beyond the periodic",
        ),
        (
            "fluid outside its periodic box",
            TG,
            "min = [0.0, 0.0]
max = [1.0, 1.0]
velocity_field",
            "min = [0.0, 1.5]
max = [1.0, 2.5]
velocity_field",
            "beyond the periodic",
        ),
        (
            "polygon vertex with z",
            TANK,
            "shape = \"box\"\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]",
            "shape = \"polygon\"\nvertices = [[0.0, 0.0], [0.5, 0.0, 1.0], [0.5, 0.5]]",
            "vertex 1 has 3 coordinates",
        ),
        (
            "rho0 1e300",
            TANK,
            "dt = 1e-3",
            "dt = 1e-3\nrho0 = 1e300",
            "rho0",
        ),
        (
            "rho0 1e-300",
            TANK,
            "dt = 1e-3",
            "dt = 1e-3\nrho0 = 1e-300",
            "rho0",
        ),
        (
            "gravity 1e300",
            TANK,
            "gravity = [0.0, -9.81, 0.0]",
            "gravity = [0.0, -1e300, 0.0]",
            "effects.gravity",
        ),
        (
            "velocity 1e200",
            TANK,
            "velocity = [0.0, 0.0]",
            "velocity = [0.0, 1e200]",
            "fluid[0].velocity",
        ),
        (
            "pressure scale 5e100",
            TANK,
            "dt = 1e-3",
            "dt = 1e-3\nrho0 = 1e100",
            "pressures of about",
        ),
        (
            "fluid inside a solid wall",
            TANK,
            "layers = 3\n",
            "layers = 3\n[[wall]]\nkind = \"solid\"\nmin = [-0.1, -0.1]\nmax = [0.6, 0.6]\n",
            "inside the solid wall[1]",
        ),
        (
            "snapshot after t_end",
            CAVITY,
            "snapshots = [0.02]",
            "snapshots = [0.5]",
            "never be written",
        ),
    ] {
        c.push(scene_case(name, base, from, to, expect));
    }
    // Mirror-ghost walls: with gravity, or in a cavity too coarse to mirror (the kernel support
    // over half the cavity: found when the run builds it).
    c.push(scene_case(
        "ghost walls with gravity",
        CAVITY,
        "reynolds = 100\n",
        "reynolds = 100\nwall_model = \"ghost\"\n",
        "cavity.wall_model",
    ));
    c.last_mut().unwrap().scene = Some(
        CAVITY
            .replacen(
                "reynolds = 100\n",
                "reynolds = 100\nwall_model = \"ghost\"\n",
                1,
            )
            .replacen(
                "shifting = { coefficient = 2.0 }\n",
                "shifting = { coefficient = 2.0 }\ngravity = [0.0, -9.81, 0.0]\n",
                1,
            ),
    );
    let mut coarse = scene_case(
        "ghost walls in a coarse cavity",
        CAVITY,
        "dx = 0.1\n",
        "dx = 0.25\n",
        "cavity.wall_model",
    );
    coarse.scene = coarse.scene.map(|s| {
        s.replacen(
            "reynolds = 100\n",
            "reynolds = 100\nwall_model = \"ghost\"\n",
            1,
        )
    });
    coarse.args = vec!["run".into()];
    c.push(coarse);
    let mut tiny = scene_case("--dx 1e-300", TANK, "dx", "dx", "too small to count");
    tiny.args = vec!["run".into(), "--dx".into(), "1e-300".into()];
    c.push(tiny);
    let mut flag = scene_case(
        "--div-r-threshold without a free surface",
        CAVITY,
        "dx",
        "dx",
        "free surface",
    );
    flag.args = vec!["run".into(), "--div-r-threshold".into(), "1.5".into()];
    c.push(flag);
    c
}

/// Runs `dgsph args... [scene]` with a time limit; returns (exit code or None for a signal,
/// output, seconds).
fn run_limited(args: &[String], scene: Option<&Path>, out: &Path) -> (Option<i32>, String, f64) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_dgsph"));
    cmd.arg(&args[0]);
    if let Some(s) = scene {
        cmd.arg(s);
    }
    cmd.args(&args[1..]);
    if args[0] == "run" {
        cmd.arg("--out").arg(out);
    }
    let t0 = Instant::now();
    let mut child = cmd
        .env("RAYON_NUM_THREADS", "2")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Drain both pipes while waiting: a child blocked on a full pipe would look like a hang.
    let drain = |mut r: Box<dyn std::io::Read + Send>| {
        std::thread::spawn(move || {
            let mut b = Vec::new();
            r.read_to_end(&mut b).ok();
            b
        })
    };
    let out_t = drain(Box::new(child.stdout.take().unwrap()));
    let err_t = drain(Box::new(child.stderr.take().unwrap()));
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if t0.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut all = out_t.join().unwrap();
    all.extend(err_t.join().unwrap());
    let output = String::from_utf8_lossy(&all).into_owned();
    (
        status.and_then(|s| s.code()),
        output,
        t0.elapsed().as_secs_f64(),
    )
}

#[test]
fn every_bad_input_is_a_clean_error() {
    let dir = scratch("bad");
    let cases = cases();
    assert!(cases.len() >= 150, "only {} cases", cases.len());
    let mut failures = Vec::new();
    println!("| # | input | exit | seconds | message |\n|---:|---|---:|---:|---|");
    for (k, case) in cases.iter().enumerate() {
        let path = case
            .scene
            .as_ref()
            .map(|text| scene(&dir, &format!("s{k}"), text));
        let (code, out, secs) =
            run_limited(&case.args, path.as_deref(), &dir.join(format!("o{k}")));
        let first = out
            .lines()
            .find(|l| l.contains("error") || l.contains("FAILED"))
            .unwrap_or("")
            .chars()
            .take(140)
            .collect::<String>();
        println!(
            "| {k} | {} | {} | {secs:.2} | {} |",
            case.name,
            code.map_or("signal".into(), |c| c.to_string()),
            first.replace('|', "/")
        );
        let ok = code.is_some_and(|c| case.codes.contains(&c))
            && !out.contains("panicked")
            && out.contains(case.expect);
        if !ok {
            failures.push(format!(
                "{}: exit {code:?}, expected {:?} containing {:?}:\n{out}",
                case.name, case.codes, case.expect
            ));
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    assert!(
        failures.is_empty(),
        "{} of {} bad inputs misbehaved:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n---\n")
    );
}

#[test]
fn checkpoints_with_impossible_values_are_refused() {
    use sph_integrators::Checkpoint;
    let dir = scratch("badck");
    let s = scene(&dir, "c", CAVITY);
    let out = dir.join("o");
    let o = dgsph(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--checkpoint-every",
        "2",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // As if killed after its last checkpoint: no run record, so --resume continues the
    // checkpoint (a finished scheme would be left as it is).
    std::fs::remove_file(out.join("c_dg.run.json")).unwrap();
    let path = out.join("c_dg.checkpoint");
    let good = Checkpoint::decode(&std::fs::read(&path).unwrap()).unwrap();
    for (what, edit) in [
        (
            "time",
            Box::new(|c: &mut Checkpoint| c.t = -5.0) as Box<dyn Fn(&mut Checkpoint)>,
        ),
        ("mass", Box::new(|c: &mut Checkpoint| c.masses[3] = 0.0)),
        (
            "density",
            Box::new(|c: &mut Checkpoint| c.densities[0] = f64::NAN),
        ),
        ("does not fit", Box::new(|c: &mut Checkpoint| c.step = 3)),
        (
            "positions",
            Box::new(|c: &mut Checkpoint| {
                // A well-formed file for one particle fewer than the scene builds.
                c.positions.pop();
                c.velocities.pop();
                c.masses.pop();
                c.densities.pop();
                c.pressures.pop();
                c.ids.pop();
            }),
        ),
        (
            "wall particles keep their slots",
            Box::new(|c: &mut Checkpoint| {
                // A permutation that moves a wall particle into the fluid's slots.
                let last = c.ids.len() - 1;
                c.ids.swap(0, last);
            }),
        ),
        (
            "not a permutation",
            Box::new(|c: &mut Checkpoint| c.ids[1] = c.ids[0]),
        ),
        (
            "truncated",
            Box::new(|c: &mut Checkpoint| {
                // Arrays of unequal length: the file is cut short.
                c.positions.pop();
            }),
        ),
        (
            "3D, the simulation 2D",
            Box::new(|c: &mut Checkpoint| {
                c.dim = 3;
                for p in c.positions.iter_mut() {
                    p[2] = 0.5;
                }
            }),
        ),
        (
            "belongs to",
            Box::new(|c: &mut Checkpoint| {
                c.meta = c.meta.replace("\"scheme\":\"dg\"", "\"scheme\":\"euler\"")
            }),
        ),
        (
            "record of the run",
            Box::new(|c: &mut Checkpoint| c.meta = "{}".into()),
        ),
    ] {
        let mut c = good.clone();
        edit(&mut c);
        std::fs::write(&path, c.encode()).unwrap();
        let o = dgsph(&[
            "run",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--resume",
        ]);
        assert_eq!(o.status.code(), Some(2), "{what}: {}", text(&o));
        assert!(text(&o).contains(what), "{what}: {}", text(&o));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn report_survives_cut_off_files() {
    let dir = scratch("report");
    let s = scene(&dir, "c", CAVITY);
    let out = dir.join("o");
    let o = dgsph(&["run", s.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // A killed run's files: the last rows cut mid-line.
    for f in ["c_dg.csv", "c_dg_u_profile.csv", "c_dg_density_t0.020.csv"] {
        let p = out.join(f);
        let t = std::fs::read_to_string(&p).unwrap();
        std::fs::write(&p, &t[..t.len() - 7]).unwrap();
    }
    let o = dgsph(&["report", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(out.join("report.md").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A scene file whose name cannot prefix output files (spaces, accents, 200 characters): the
/// error names the file and suggests `--tag`; with `--tag` the same scene runs.
#[test]
fn a_scene_name_that_cannot_name_files_suggests_tag() {
    let dir = scratch("names");
    for stem in ["my scene", "scène", &"s".repeat(200)] {
        let path = dir.join(format!("{stem}.toml"));
        std::fs::write(&path, CAVITY).unwrap();
        let out = dir.join("o");
        let o = dgsph(&[
            "run",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{stem}: {}", text(&o));
        assert!(text(&o).contains("--tag"), "{stem}: {}", text(&o));
        let o = dgsph(&[
            "run",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--tag",
            "named",
        ]);
        assert_eq!(o.status.code(), Some(0), "{stem}: {}", text(&o));
    }
    std::fs::remove_dir_all(&dir).ok();
}
