//! The cases by [`CaseKind`]: how to build each one, what results it reports, which figures a
//! report draws from its records, and the checks across a scene's schemes. The dimension is
//! chosen here, once, at the edge ([`run_scheme`]).
//!
//! Adding a case: write its file (a type implementing [`Case`]), add its kind to [`CaseKind`]
//! and one arm to each `match` below.

use crate::case::{Case, Results};
use crate::figures::{Figure, Series};
use crate::reference::References;
use crate::run::{COMMON_RESULTS, RunControl, RunSink, SchemeRun};
use crate::{CaseError, CaseKind, Check, Scene};
use sph_core::{D2, D3, Dim};
use sph_integrators::SchemeKind;

/// The case of `scene` for one scheme's run, in dimension `D`.
pub fn case<D: Dim>(scene: &Scene, scheme: SchemeKind, refs: &References) -> Box<dyn Case<D>> {
    match scene.case {
        CaseKind::Flow => Box::new(crate::flow::FlowCase::new(scene)),
        CaseKind::DamBreak => Box::new(crate::dam_break::DamBreakCase::new(scene, refs)),
        CaseKind::EllipticalDrop | CaseKind::SpheroidDrop => {
            Box::new(crate::drop::DropCase::new::<D>(scene, refs))
        }
        CaseKind::PrescribedEllipse | CaseKind::PrescribedEllipsoid => Box::new(
            crate::prescribed::PrescribedCase::<D>::new(scene, scheme, refs),
        ),
        CaseKind::LidDrivenCavity => Box::new(crate::cavity::CavityCase::<D>::new(scene, refs)),
    }
}

/// Runs one scheme of `scene` (see [`crate::run::run_scheme`]), in the scene's dimension.
pub fn run_scheme(
    scene: &Scene,
    scheme: SchemeKind,
    refs: &References,
    control: RunControl<'_>,
    sink: &mut dyn RunSink,
) -> Result<SchemeRun, CaseError> {
    match scene.dim {
        2 => crate::run::run_scheme::<D2>(
            scene,
            scheme,
            case::<D2>(scene, scheme, refs),
            control,
            sink,
        ),
        3 => crate::run::run_scheme::<D3>(
            scene,
            scheme,
            case::<D3>(scene, scheme, refs),
            control,
            sink,
        ),
        d => Err(CaseError::Invalid {
            scene: scene.case.name().into(),
            field: "dim".into(),
            message: format!("must be 2 or 3, got {d}"),
        }),
    }
}

/// The checks of one scheme's finished run from its recorded results (`t`: the time it
/// reached; `failure`: its step error, if it stopped at one), as [`run_scheme`] made them: for
/// a run whose results were read back rather than run again (a resumed scene's finished
/// schemes).
pub fn run_checks(
    scene: &Scene,
    scheme: SchemeKind,
    refs: &References,
    results: &crate::Results,
    t: f64,
    failure: Option<&str>,
) -> Vec<crate::Check> {
    match scene.dim {
        3 => crate::run::run_checks::<D3>(
            scene,
            scheme,
            case::<D3>(scene, scheme, refs).as_ref(),
            results,
            t,
            failure,
        ),
        _ => crate::run::run_checks::<D2>(
            scene,
            scheme,
            case::<D2>(scene, scheme, refs).as_ref(),
            results,
            t,
            failure,
        ),
    }
}

/// The results a case reports besides the run loop's ([`COMMON_RESULTS`]).
pub fn case_results(kind: CaseKind) -> Vec<&'static str> {
    match kind {
        CaseKind::Flow => crate::flow::RESULTS.to_vec(),
        CaseKind::DamBreak => [&crate::flow::RESULTS[..], &crate::dam_break::RESULTS[..]].concat(),
        CaseKind::EllipticalDrop | CaseKind::SpheroidDrop => vec![
            "t_last_full_step",
            "volume_change",
            "volume_change_hull",
            "a_moments",
            "b_moments",
            "a_extent",
            "b_extent",
            "a_exact",
            "b_exact",
            "a_error_moments",
            "b_error_moments",
            "a_error_extent",
            "b_error_extent",
            "p_centre",
            "p_centre_exact",
            "p_centre_error",
            "semi_axis_error_max",
            "volume_change_max",
            "t_departure",
            "semi_axis_error_resolved_max",
            "t_resolved",
        ],
        CaseKind::PrescribedEllipse | CaseKind::PrescribedEllipsoid => {
            vec!["slope_hull", "slope_moments", "exact_slope", "table_slope"]
        }
        CaseKind::LidDrivenCavity => vec![
            "pressure_drift",
            "steady_time",
            "ghia_u_rms",
            "ghia_u_max",
            "ghia_v_rms",
            "ghia_v_max",
        ],
    }
}

/// Case-specific validation of a scene beyond [`Scene::validate`]: the schemes a case accepts
/// and the result names of its `[[check]]` tables.
pub fn validate(scene: &Scene, name: &str) -> Result<(), CaseError> {
    let bad = |field: String, message: String| {
        Err(CaseError::Invalid {
            scene: name.to_string(),
            field,
            message,
        })
    };
    if matches!(
        scene.case,
        CaseKind::PrescribedEllipse | CaseKind::PrescribedEllipsoid
    ) && scene.schemes.contains(&SchemeKind::Dg)
    {
        return bad(
            "schemes".into(),
            "a prescribed-field case compares the euler and predictor_corrector position \
             updates; dg has none of its own"
                .into(),
        );
    }
    if scene.case == CaseKind::DamBreak {
        crate::dam_break::validate(scene, name)?;
    }
    let own = case_results(scene.case);
    for (i, c) in scene.check.iter().enumerate() {
        if !COMMON_RESULTS.contains(&c.quantity.as_str()) && !own.contains(&c.quantity.as_str()) {
            let mut all: Vec<&str> = COMMON_RESULTS.iter().chain(&own).copied().collect();
            all.sort_unstable();
            return bad(
                format!("check[{i}].quantity"),
                format!(
                    "{:?} is not a result of a {} run (results: {})",
                    c.quantity,
                    scene.case.name(),
                    all.join(", ")
                ),
            );
        }
    }
    Ok(())
}

/// Parses and validates a scene completely (schema, values, case-specific rules).
pub fn parse_scene(name: &str, text: &str) -> Result<Scene, CaseError> {
    let scene = Scene::parse(name, text)?;
    validate(&scene, name)?;
    Ok(scene)
}

/// Checks across the schemes of one scene (`runs`: each scheme's results).
pub fn scene_checks(scene: &Scene, runs: &[(SchemeKind, &Results)]) -> Vec<Check> {
    let find = |k: SchemeKind| runs.iter().find(|(s, _)| *s == k).map(|(_, r)| *r);
    match scene.case {
        CaseKind::EllipticalDrop | CaseKind::SpheroidDrop => {
            // The paper's claim is for the paper's run length (a long drop is judged by its
            // scene's checks on the departure results).
            let paper_range = scene.t_end
                <= crate::reference::References::embedded()
                    .drop(scene.dim)
                    .t_max();
            match (find(SchemeKind::Euler), find(SchemeKind::Dg)) {
                (Some(e), Some(d)) if paper_range => {
                    vec![crate::drop::euler_vs_dg_check(scene.case.name(), e, d)]
                }
                _ => Vec::new(),
            }
        }
        _ => Vec::new(),
    }
}

/// The figures a report draws for a run of `kind` (from its record columns and tables).
pub fn figures(kind: CaseKind, dim: usize) -> Vec<Figure> {
    let common = || {
        vec![Figure::lines(
            "energy",
            "kinetic energy",
            "t",
            "kinetic energy",
            vec![Series::per_scheme("kinetic_energy")],
        )]
    };
    match kind {
        CaseKind::DamBreak => {
            let mut f = vec![Figure::lines(
                "front",
                "surge front against Martin & Moyce (1952)",
                "time_T",
                "Z = z/a",
                vec![
                    Series::per_scheme("front_Z"),
                    Series::reference("front_Z_reference", "Martin & Moyce (1952)"),
                ],
            )];
            f.extend(common());
            f
        }
        CaseKind::Flow => {
            let mut f = common();
            f.push(Figure::lines(
                "centroid",
                "height of the fluid's centroid",
                "t",
                "centroid y",
                vec![Series::per_scheme("centroid_y")],
            ));
            f
        }
        CaseKind::EllipticalDrop | CaseKind::SpheroidDrop => vec![
            Figure::lines(
                "volume",
                "relative volume change (Fig. 3)",
                "t",
                "ΔV/V₀ (second moments)",
                vec![Series::per_scheme("rel_change_moments")],
            ),
            Figure::lines(
                "axes",
                "semi-axes against the exact solution (Fig. 3)",
                "t",
                "semi-axis",
                vec![
                    Series::per_scheme("a_moments"),
                    Series::per_scheme("b_moments"),
                    Series::per_scheme("a_extent"),
                    Series::per_scheme("b_extent"),
                    Series::exact("a_exact"),
                    Series::exact("b_exact"),
                ],
            ),
        ],
        CaseKind::PrescribedEllipse | CaseKind::PrescribedEllipsoid => vec![Figure::lines(
            "volume",
            "volume under a prescribed divergence-free field (Fig. 1)",
            "t",
            "V (convex hull)",
            vec![Series::per_scheme("measure_hull")],
        )],
        CaseKind::LidDrivenCavity => {
            let mut f = vec![Figure::lines(
                "density_error",
                "RMS density error, Eq. 31 (Figs. 7, 9)",
                "t",
                "RMS of ρ̂/ρ₀ − 1",
                vec![Series::per_scheme("density_error_rms")],
            )];
            if dim == 2 {
                f.push(Figure::lines(
                    "ghia_history",
                    "RMS deviation from Ghia et al. against time",
                    "t",
                    "RMS deviation",
                    vec![
                        Series::per_scheme("ghia_u_rms"),
                        Series::per_scheme("ghia_v_rms"),
                    ],
                ));
                f.push(Figure::table_lines(
                    "u_profile",
                    "u(0.5, y) against Ghia et al. (Figs. 4–6)",
                    "u_profile",
                    "y",
                    "u(0.5, y)/U",
                    vec![
                        Series::per_scheme("u"),
                        Series::reference("u_ghia", "Ghia et al. (1982)"),
                    ],
                ));
                f.push(Figure::table_lines(
                    "v_profile",
                    "v(x, 0.5) against Ghia et al. (Figs. 4–6)",
                    "v_profile",
                    "x",
                    "v(x, 0.5)/U",
                    vec![
                        Series::per_scheme("v"),
                        Series::reference("v_ghia", "Ghia et al. (1982)"),
                    ],
                ));
            }
            f.push(Figure::heat_map(
                "density",
                "density-error field ρ̂/ρ₀ − 1 (Figs. 8, 10)",
                "density_t",
                "density_error",
            ));
            f.extend(common());
            f
        }
    }
}

/// Builds the initial state of `scene` (first scheme) and returns its particle counts
/// `(fluid, walls, carved)` (`carved`: fluid lattice sites left out inside walls), without
/// running anything.
pub fn particle_counts(
    scene: &Scene,
    refs: &References,
) -> Result<(usize, usize, usize), CaseError> {
    fn counts<D: Dim>(
        scene: &Scene,
        refs: &References,
    ) -> Result<(usize, usize, usize), CaseError> {
        let scheme = scene.schemes.first().copied().unwrap_or(SchemeKind::Dg);
        let s = case::<D>(scene, scheme, refs).setup()?;
        let n = s.particles.len();
        let fluid = s.walls.as_ref().map_or(n, |w| w.first);
        Ok((fluid, n - fluid, s.carved))
    }
    match scene.dim {
        2 => counts::<D2>(scene, refs),
        3 => counts::<D3>(scene, refs),
        d => Err(CaseError::Invalid {
            scene: scene.case.name().into(),
            field: "dim".into(),
            message: format!("must be 2 or 3, got {d}"),
        }),
    }
}
