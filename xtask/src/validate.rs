//! `cargo xtask validate`.

use crate::flags::{Suite, ValidateArgs};
use anyhow::Context;
use dgsph::session::{self, AppError, RunOptions, exit};
use dgsph::summary::{CheckRecord, SCHEMA_VERSION, Summary};
use sph_cases::Check;
use sph_cases::reference::References;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The reference set: the compiled-in copy of `cases/reference/`, with the files present in
/// `dir` (if given) read in its place.
pub fn load_references(dir: Option<&Path>) -> anyhow::Result<References> {
    let Some(dir) = dir else {
        return Ok(References::embedded().clone());
    };
    anyhow::ensure!(
        dir.is_dir(),
        "--references {}: not a directory",
        dir.display()
    );
    let mut replaced = Vec::new();
    let mut failed = None;
    let refs = References::parse(|file| {
        let path = dir.join(file);
        if !path.exists() {
            return None;
        }
        match std::fs::read_to_string(&path) {
            Ok(text) => {
                replaced.push(file.to_string());
                Some(text)
            }
            Err(e) => {
                failed.get_or_insert(format!("reading {}: {e}", path.display()));
                None
            }
        }
    })
    .with_context(|| format!("reference tables from {}", dir.display()))?;
    if let Some(message) = failed {
        anyhow::bail!(message);
    }
    dgsph::say!(
        "references: {} from {} (others compiled in)",
        if replaced.is_empty() {
            "none".to_string()
        } else {
            replaced.join(", ")
        },
        dir.display()
    );
    Ok(refs)
}

/// Runs the selected scenes; returns the exit code.
pub fn run(args: &ValidateArgs) -> Result<u8, AppError> {
    let t0 = Instant::now();
    // The revision at launch (what `cargo xtask` just built), not at the end of a long run
    // during which the tree may have moved on.
    let git = dgsph::git_revision();
    let refs = load_references(args.references.as_deref()).map_err(AppError::Input)?;
    let cases_dir = args.cases.clone().unwrap_or_else(|| match args.suite {
        Suite::Default => PathBuf::from("cases"),
        Suite::Hard => PathBuf::from("cases/hard"),
    });
    if args.sweep {
        crate::sweep::run(&cases_dir, &args.out, &refs, &args.study)?;
        return Ok(exit::OK);
    }
    let wants = |name: &str| args.case.as_deref().is_none_or(|c| name.contains(c));
    let mut checks: Vec<(Check, f64)> = Vec::new();
    let mut runs = Vec::new();
    let mut bad_input = false;
    let mut failed_runs = 0;
    let mut interrupted = None;
    if args.suite == Suite::Default
        && (wants("kernels") || wants("operators") || wants("foundation"))
    {
        let t = Instant::now();
        let found: Vec<Check> = sph_cases::foundation::checks()
            .into_iter()
            .filter(|c| wants(&c.case) || wants("foundation"))
            .collect();
        let wall = t.elapsed().as_secs_f64();
        checks.extend(found.into_iter().map(|c| (c, wall)));
    }
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(&cases_dir)
        .with_context(|| format!("reading scene directory {}", cases_dir.display()))
        .map_err(AppError::Input)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    scenes.sort();
    if scenes.is_empty() {
        return Err(AppError::Input(anyhow::anyhow!(
            "scene directory {} holds no scene (*.toml)",
            cases_dir.display()
        )));
    }
    for path in scenes {
        let name = session::scene_stem(&path);
        let scene = match session::load_scene(&path) {
            Ok(s) => s,
            // A malformed scene fails the run only when it is selected (by its file stem: its
            // kind is unknown); the others still run and the summary is written.
            Err(e) if wants(&name) => {
                dgsph::warn!("{}: {e}", path.display());
                bad_input = true;
                checks.push((
                    Check::new(name.clone(), "scene parses", 0.0, 1.0, 0.0, e.to_string()),
                    0.0,
                ));
                continue;
            }
            Err(e) => {
                dgsph::warn!(
                    "{}: skipped (not selected), and it does not parse: {e}",
                    path.display()
                );
                continue;
            }
        };
        if !wants(scene.case.name()) && !wants(&name) {
            continue;
        }
        dgsph::say!("{} ({} preset)", path.display(), args.preset.name());
        let scene = args.preset.apply(&scene);
        let outcome = session::run_scene(
            &scene,
            &refs,
            &RunOptions {
                out: args.out.clone(),
                name: name.clone(),
                checkpoint_every: args.checkpoint_every.map(|n| n as usize),
                resume: args.resume,
                vtk: args.vtk,
                frame_every: args.frame_every.map(|n| n as usize),
                progress_every: 10.0,
                verbose: true,
                stop: dgsph::signals::installed(),
            },
        );
        match outcome {
            Ok(o) => {
                dgsph::say!("  [{:.1} s]", o.wall_s);
                failed_runs += o.unexpected_failed_runs;
                checks.extend(o.checks.into_iter().map(|c| (c, o.wall_s)));
                runs.extend(o.runs);
            }
            Err(AppError::Input(e)) => {
                dgsph::warn!("{}: {e:#}", path.display());
                bad_input = true;
                checks.push((
                    Check::new(name, "scene runs", 0.0, 1.0, 0.0, format!("{e:#}")),
                    0.0,
                ));
            }
            // A signal: the scenes finished so far go into the summary, then the command
            // exits with the signal's code (the interrupted scene's checkpoint and run.json are
            // written; `--resume` continues it).
            Err(e @ AppError::Interrupted { .. }) => {
                interrupted = Some(e);
                break;
            }
            Err(e) => return Err(e),
        }
    }
    if checks.is_empty() && interrupted.is_none() {
        return Err(AppError::Input(anyhow::anyhow!(
            "no validation case matches {:?} in {}",
            args.case,
            cases_dir.display()
        )));
    }
    let plain: Vec<Check> = checks.iter().map(|(c, _)| c.clone()).collect();
    let passed = dgsph::cli::print_checks(&plain);
    let wall_s = t0.elapsed().as_secs_f64();
    dgsph::say!("({} preset, {wall_s:.1} s)", args.preset.name());
    let summary = Summary {
        schema_version: SCHEMA_VERSION,
        preset: args.preset.name().to_string(),
        suite: args.suite.name().to_string(),
        git,
        references: args
            .references
            .as_ref()
            .map_or("compiled-in cases/reference".to_string(), |d| {
                d.display().to_string()
            }),
        passed: passed && failed_runs == 0 && !bad_input && interrupted.is_none(),
        wall_s,
        checks: checks
            .iter()
            .map(|(c, w)| CheckRecord::new(c, *w))
            .collect(),
        runs,
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating output directory {}", args.out.display()))
        .map_err(AppError::Output)?;
    let path = args.out.join("summary.json");
    let json = serde_json::to_vec_pretty(&summary)
        .context("encoding summary.json")
        .map_err(AppError::Output)?;
    dgsph::output::write_atomic(&path, &json)
        .with_context(|| format!("writing {}", path.display()))
        .map_err(AppError::Output)?;
    // The file must read back into the same struct (the schema other tools rely on).
    let back: Summary = std::fs::read(&path)
        .context("reading summary.json back")
        .and_then(|b| serde_json::from_slice(&b).context("summary.json does not match its schema"))
        .map_err(AppError::Output)?;
    if back != summary {
        return Err(AppError::Output(anyhow::anyhow!(
            "summary.json does not read back into the summary written"
        )));
    }
    dgsph::say!("summary: {} (read back: identical)", path.display());
    let report = dgsph::report::write(&args.out).map_err(AppError::Output)?;
    dgsph::say!("report: {}", report.display());
    if let Some(e) = interrupted {
        return Err(e);
    }
    Ok(if bad_input {
        exit::BAD_INPUT
    } else if failed_runs > 0 {
        exit::RUN_FAILED
    } else if passed {
        exit::OK
    } else {
        exit::CHECKS_FAILED
    })
}
