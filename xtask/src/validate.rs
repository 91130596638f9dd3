//! `cargo xtask validate`.

use crate::flags::ValidateArgs;
use anyhow::Context;
use sph_cases::Check;
use std::time::Instant;

/// Runs the selected cases; returns `Ok(true)` if every check passed.
pub fn run(args: &ValidateArgs) -> anyhow::Result<bool> {
    let t0 = Instant::now();
    // The revision at launch (what `cargo xtask` just built), not at the end of a long run
    // during which the tree may have moved on.
    let git = git_revision();
    let mut checks: Vec<(Check, f64)> = Vec::new();
    let mut runs = Vec::new();
    let refs = crate::run::load_references(args.references.as_deref())?;
    if args.sweep {
        crate::sweep::run(&args.cases, &args.out, &refs)?;
        return Ok(true);
    }
    let wants = |name: &str| args.case.as_deref().is_none_or(|c| name.contains(c));
    if wants("kernels") || wants("operators") || wants("foundation") {
        let t = Instant::now();
        let found: Vec<Check> = sph_cases::foundation::checks()
            .into_iter()
            .filter(|c| wants(&c.case) || wants("foundation"))
            .collect();
        let wall = t.elapsed().as_secs_f64();
        checks.extend(found.into_iter().map(|c| (c, wall)));
    }
    let mut scenes: Vec<_> = std::fs::read_dir(&args.cases)
        .with_context(|| format!("reading scene directory {}", args.cases.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    scenes.sort();
    for path in scenes {
        let scene = crate::run::load_scene(&path)?;
        let name = crate::run::scene_stem(&path);
        if !wants(scene.case.name()) && !wants(&name) {
            continue;
        }
        println!("{} ({:?} preset)", path.display(), args.preset);
        let t = Instant::now();
        let result = crate::run::run_scene(
            &scene,
            &name,
            args.preset,
            &refs,
            &args.out,
            &crate::run::RunOptions {
                frame_stride: args.frame_stride,
                checkpoint_every: args.checkpoint_every,
                resume: args.resume,
            },
        )?;
        let wall = t.elapsed().as_secs_f64();
        checks.extend(result.checks.into_iter().map(|c| (c, wall)));
        runs.extend(result.runs);
        println!("  [{wall:.1} s]");
    }
    if checks.is_empty() {
        anyhow::bail!("no validation case matches {:?}", args.case);
    }
    let plain: Vec<Check> = checks.iter().map(|(c, _)| c.clone()).collect();
    let passed = print_checks(&plain);
    println!(
        "({:?} preset, {:.1} s)",
        args.preset,
        t0.elapsed().as_secs_f64()
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating output directory {}", args.out.display()))?;
    let summary = args.out.join("summary.json");
    // Field names are part of the interface (documented in the README); keep them stable.
    let json = serde_json::json!({
        "preset": format!("{:?}", args.preset).to_lowercase(),
        "git": git,
        "references": args.references.as_ref().map_or("compiled-in cases/reference".to_string(), |d| d.display().to_string()),
        "passed": passed,
        "checks": checks.iter().map(|(c, wall_s)| serde_json::json!({
            "case": c.case, "check": c.name, "value": c.value, "reference": c.reference,
            "tolerance": c.tolerance, "pass": c.passed(), "wall_s": wall_s, "source": c.source,
        })).collect::<Vec<_>>(),
        "runs": runs,
    });
    std::fs::write(&summary, serde_json::to_string_pretty(&json)?)
        .with_context(|| format!("writing {}", summary.display()))?;
    println!("summary: {}", summary.display());
    let report = crate::report::write(&args.out)?;
    println!("report: {}", report.display());
    Ok(passed)
}

/// `git rev-parse HEAD` (with `-dirty` if the tree has changes), or `"unknown"`.
fn git_revision() -> String {
    let run = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match run(&["rev-parse", "HEAD"]) {
        Some(rev) if run(&["status", "--porcelain"]).is_some_and(|s| !s.is_empty()) => {
            format!("{rev}-dirty")
        }
        Some(rev) => rev,
        None => "unknown".to_string(),
    }
}

/// Prints the pass/fail table; returns true if every check passed.
pub fn print_checks(checks: &[Check]) -> bool {
    println!(
        "\n{:<20} {:<48} {:>14} {:>14} {:>10}  result",
        "case", "check", "value", "reference", "tolerance"
    );
    for c in checks {
        println!(
            "{:<20} {:<48} {:>14.6e} {:>14.6e} {:>10.1e}  {}",
            c.case,
            c.name,
            c.value,
            c.reference,
            c.tolerance,
            if c.passed() { "pass" } else { "FAIL" }
        );
    }
    let failed = checks.iter().filter(|c| !c.passed()).count();
    println!(
        "\n{} checks: {} passed, {} failed",
        checks.len(),
        checks.len() - failed,
        failed
    );
    failed == 0
}
