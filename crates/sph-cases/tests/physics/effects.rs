//! Only declared effects run: every step records which passes ran (the `seconds_<pass>`
//! columns are empty for a pass that did not run), through the path users take (scene text →
//! registry → run loop → records).

use crate::support::run;
use sph_cases::registry::parse_scene;
use sph_cases::run::MemorySink;
use sph_integrators::SchemeKind;

/// True if pass `name` ran in any step record (the initial record has no step).
fn ran(sink: &MemorySink, name: &str) -> bool {
    let col = sink.column(&format!("seconds_{name}"));
    assert!(!col.is_empty(), "no column seconds_{name}");
    col.iter().skip(1).any(|v| !v.is_nan())
}

const DROP: &str = "case = \"elliptical_drop\"\ndim = 2\ndx = 0.1\ndt = 2e-4\nt_end = 6e-4\nschemes = [\"euler\", \"predictor_corrector\", \"dg\"]\n[free_surface]\n";

#[test]
fn an_inviscid_drop_runs_no_viscosity_gravity_wall_or_shifting_pass() {
    let scene = parse_scene("drop", DROP).unwrap();
    for kind in SchemeKind::ALL {
        let (_, sink) = run(&scene, kind);
        for absent in [
            "viscosity",
            "hyperviscosity",
            "gravity",
            "wall_data",
            "shifting",
            "diagnostics",
        ] {
            assert!(!ran(&sink, absent), "{kind:?}: {absent} ran");
        }
        for present in [
            "neighbors",
            "free_surface",
            "source",
            "assembly",
            "solve",
            "correction",
        ] {
            assert!(ran(&sink, present), "{kind:?}: {present} did not run");
        }
        // Without walls nothing is ever guarded.
        assert!(
            sink.column("wall_guarded")
                .iter()
                .skip(1)
                .all(|v| *v == 0.0)
        );
    }
}

#[test]
fn a_closed_box_runs_no_free_surface_pass_and_has_no_dirichlet_rows() {
    let cavity = "case = \"lid_driven_cavity\"\ndim = 2\ndx = 0.1\nkernel = \"wendland_c2\"\ndt = 0.01\nt_end = 0.03\nschemes = [\"euler\", \"predictor_corrector\", \"dg\"]\n[cavity]\nreynolds = 100\n";
    let scene = parse_scene("cavity", cavity).unwrap();
    for kind in SchemeKind::ALL {
        let (_, sink) = run(&scene, kind);
        assert!(!ran(&sink, "free_surface"), "{kind:?}");
        assert!(
            !ran(&sink, "gravity") && !ran(&sink, "shifting"),
            "{kind:?}"
        );
        assert!(
            ran(&sink, "viscosity") && ran(&sink, "wall_data"),
            "{kind:?}"
        );
        let dirichlet = sink.column("free_surface_particles");
        assert!(
            dirichlet.iter().skip(1).all(|v| *v == 0.0),
            "{kind:?}: {dirichlet:?}"
        );
    }
}

#[test]
fn diagnostics_run_only_when_the_output_asks_for_them() {
    for (extra, det_f, div_u) in [
        ("", false, false),
        ("[output]\ndiagnostics = [\"det_f\"]\n", true, false),
        ("[output]\ndiagnostics = [\"div_u\"]\n", false, true),
        (
            "[output]\ndiagnostics = [\"det_f\", \"div_u\"]\n",
            true,
            true,
        ),
    ] {
        let scene = parse_scene("drop", &format!("{DROP}{extra}")).unwrap();
        for kind in SchemeKind::ALL {
            let (_, sink) = run(&scene, kind);
            assert_eq!(
                ran(&sink, "diagnostics"),
                det_f || div_u,
                "{kind:?} {extra}"
            );
            let has = |c: &str| sink.column(c).iter().skip(1).any(|v| !v.is_nan());
            assert_eq!(has("det_f_mean"), det_f, "{kind:?} {extra}");
            assert_eq!(has("max_div_u"), div_u, "{kind:?} {extra}");
        }
    }
}

#[test]
fn gravity_walls_and_shifting_run_when_declared() {
    let tank = "dim = 2\ndx = 0.1\nkernel = \"wendland_c2\"\ndt = 1e-3\nt_end = 3e-3\nschemes = [\"dg\"]\n[[fluid]]\nshape = \"box\"\nmin = [0.0, 0.0]\nmax = [1.0, 0.5]\n[[wall]]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\nopen = [\"+y\"]\n[free_surface]\n[effects]\ngravity = [0.0, -9.81, 0.0]\nshifting = { coefficient = 2.0 }\n";
    let (_, sink) = run(&parse_scene("tank", tank).unwrap(), SchemeKind::Dg);
    for present in ["gravity", "wall_data", "shifting", "free_surface"] {
        assert!(ran(&sink, present), "{present}");
    }
    assert!(!ran(&sink, "viscosity"));
}
