//! `cargo xtask validate`.

use crate::flags::ValidateArgs;
use anyhow::Context;
use sph_cases::Check;
use std::time::Instant;

/// Runs the selected cases; returns `Ok(true)` if every check passed.
pub fn run(args: &ValidateArgs) -> anyhow::Result<bool> {
    let t0 = Instant::now();
    let mut checks: Vec<Check> = Vec::new();
    let wants = |name: &str| args.case.as_deref().is_none_or(|c| name.contains(c));
    if wants("kernels") || wants("operators") || wants("foundation") {
        checks.extend(
            sph_cases::foundation::checks()
                .into_iter()
                .filter(|c| wants(&c.case) || wants("foundation")),
        );
    }
    let mut scenes: Vec<_> = std::fs::read_dir(&args.cases)
        .with_context(|| format!("reading scene directory {}", args.cases.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    scenes.sort();
    for path in scenes {
        let scene = crate::run::load_scene(&path)?;
        if !wants(scene.case.name()) {
            continue;
        }
        println!("{} ({:?} preset)", path.display(), args.preset);
        let t = Instant::now();
        checks.extend(crate::run::run_scene(&scene, args.preset, &args.out)?);
        println!("  [{:.1} s]", t.elapsed().as_secs_f64());
    }
    if checks.is_empty() {
        anyhow::bail!("no validation case matches {:?}", args.case);
    }
    let passed = print_checks(&checks);
    println!(
        "({:?} preset, {:.1} s)",
        args.preset,
        t0.elapsed().as_secs_f64()
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating output directory {}", args.out.display()))?;
    let summary = args.out.join("summary.json");
    let json = serde_json::json!({
        "preset": format!("{:?}", args.preset).to_lowercase(),
        "passed": passed,
        "checks": checks.iter().map(|c| serde_json::json!({
            "case": c.case, "name": c.name, "value": c.value, "reference": c.reference,
            "tolerance": c.tolerance, "source": c.source, "passed": c.passed(),
        })).collect::<Vec<_>>(),
    });
    std::fs::write(&summary, serde_json::to_string_pretty(&json)?)
        .with_context(|| format!("writing {}", summary.display()))?;
    println!("summary: {}", summary.display());
    Ok(passed)
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
