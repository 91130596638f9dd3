//! `cargo xtask interleave --a CMD --b CMD [--pairs N]`: two commands timed in alternation
//! (A, B, A, B, …), so that a machine whose speed drifts between minutes (a shared VM, other
//! processes on the cores) slows both alike, and speeds are quoted as ratios of interleaved
//! runs with the load stated.
//!
//! Each command runs through `sh -c` (so it may set variables or change directory: `cd
//! /tmp/wt && RAYON_NUM_THREADS=1 target/release/xtask run …`), its standard output and error
//! to `DIR/run-<k>-<label>.log`. Per run it records the one-minute load average just before
//! the run (`/proc/loadavg`; none where that file does not exist), the wall time of the whole
//! command, and the step time the command printed: the number before the first ` s/step` in
//! its output (`dgsph run` and `xtask run` print one per run; a command printing several is
//! read at its first, and the count is recorded), or none. The summary gives each side's
//! mean and SD of both times, the ratio B/A of the means and the range of the pairs' ratios
//! (run 2k+1 against run 2k+2). It judges nothing.
//!
//! Writes `interleave.csv` after every run (a run that fails leaves the earlier ones on disk)
//! and `interleave.md` at the end, and prints the table. A command that exits with a failure
//! status, or cannot be started, stops the series: exit 3 (a failed run, as `dgsph run` and
//! `xtask ensemble` use it) with a message naming the run, its label and log. A bad label is
//! bad input (exit 2).

use crate::ensemble::stats;
use crate::flags::InterleaveArgs;
use anyhow::{Context, anyhow};
use dgsph::session::{AppError, exit};
use std::fmt::Write as _;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

/// The CSV's header line.
pub const CSV_HEADER: &str = "run,side,label,wall_s,s_per_step,step_figures,load1_before";

/// One timed run.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// 1-based position in the series.
    pub run: usize,
    /// 'A' or 'B'.
    pub side: char,
    /// Wall time of the whole command (s).
    pub wall_s: f64,
    /// The first step time the command printed (s per step).
    pub s_per_step: Option<f64>,
    /// How many ` s/step` figures its output held.
    pub step_figures: usize,
    /// One-minute load average just before the run.
    pub load1: Option<f64>,
}

/// Every number printed just before ` s/step` in `text`, in order.
pub fn step_times(text: &str) -> Vec<f64> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find(" s/step") {
        let before = rest[..at].trim_end();
        let token = before
            .rsplit(|c: char| c.is_whitespace())
            .next()
            .unwrap_or("");
        if let Ok(v) = token.parse::<f64>() {
            out.push(v);
        }
        rest = &rest[at + " s/step".len()..];
    }
    out
}

/// The one-minute load average, where the system gives it.
fn load1() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or("—".to_string(), |v| format!("{v:.digits$}"))
}

/// The CSV of `runs`.
pub fn csv(runs: &[Run], labels: [&str; 2]) -> String {
    let mut s = format!("{CSV_HEADER}\n");
    for r in runs {
        let label = labels[usize::from(r.side == 'B')];
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:e}"));
        let _ = writeln!(
            s,
            "{},{},{label},{:e},{},{},{}",
            r.run,
            r.side,
            r.wall_s,
            opt(r.s_per_step),
            r.step_figures,
            opt(r.load1)
        );
    }
    s
}

/// `mean ± SD` of the values, or "—" when a run lacks one.
fn mean_sd(values: &[Option<f64>]) -> (Option<f64>, String) {
    let v: Option<Vec<f64>> = values.iter().copied().collect();
    match v {
        Some(v) if !v.is_empty() => {
            let s = stats(&v);
            let sd = if s.sd.is_finite() {
                format!(" ± {:.4}", s.sd)
            } else {
                String::new()
            };
            (Some(s.mean), format!("{:.4}{sd}", s.mean))
        }
        _ => (None, "—".to_string()),
    }
}

/// The ratio B/A of the means and the range of the pairs' ratios, for the quantity `f`.
fn ratios(runs: &[Run], f: impl Fn(&Run) -> Option<f64>) -> (String, String, String, String) {
    let side = |c: char| {
        runs.iter()
            .filter(|r| r.side == c)
            .map(&f)
            .collect::<Vec<_>>()
    };
    let (a, a_text) = mean_sd(&side('A'));
    let (b, b_text) = mean_sd(&side('B'));
    let ratio = match (a, b) {
        (Some(a), Some(b)) if a > 0.0 => format!("{:.3}", b / a),
        _ => "—".to_string(),
    };
    let pairs: Option<Vec<f64>> = runs
        .chunks(2)
        .filter(|p| p.len() == 2)
        .map(|p| match (f(&p[0]), f(&p[1])) {
            (Some(a), Some(b)) if a > 0.0 => Some(b / a),
            _ => None,
        })
        .collect();
    let range = match pairs {
        Some(p) if !p.is_empty() => {
            let s = stats(&p);
            format!("{:.3} – {:.3}", s.min, s.max)
        }
        _ => "—".to_string(),
    };
    (a_text, b_text, ratio, range)
}

/// The Markdown report of `runs`.
pub fn markdown(runs: &[Run], labels: [&str; 2], commands: [&str; 2]) -> String {
    let mut md = String::from("# Interleaved runs\n\n");
    for (k, side) in ['A', 'B'].iter().enumerate() {
        let _ = writeln!(md, "- {side} (`{}`): `{}`", labels[k], commands[k]);
    }
    md.push_str("\n| run | side | wall (s) | s/step | load before |\n|---:|---|---:|---:|---:|\n");
    for r in runs {
        let label = labels[usize::from(r.side == 'B')];
        let step = match (r.s_per_step, r.step_figures) {
            (Some(v), n) if n > 1 => format!("{v:.4} (first of {n})"),
            (v, _) => cell(v, 4),
        };
        let _ = writeln!(
            md,
            "| {} | {} {label} | {:.2} | {step} | {} |",
            r.run,
            r.side,
            r.wall_s,
            cell(r.load1, 2)
        );
    }
    let _ = write!(
        md,
        "\n| | A `{}` | B `{}` | B/A of the means | B/A per pair |\n|---|---:|---:|---:|---:|\n",
        labels[0], labels[1]
    );
    for (name, row) in [
        ("wall (s), mean ± SD", ratios(runs, |r| Some(r.wall_s))),
        ("s/step, mean ± SD", ratios(runs, |r| r.s_per_step)),
    ] {
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {} | {} |",
            row.0, row.1, row.2, row.3
        );
    }
    let loads: Vec<f64> = runs.iter().filter_map(|r| r.load1).collect();
    if !loads.is_empty() {
        let s = stats(&loads);
        let _ = writeln!(
            md,
            "\nOne-minute load average before the runs: {:.2} – {:.2}.",
            s.min, s.max
        );
    }
    md
}

/// Runs the series.
pub fn run(args: &InterleaveArgs) -> Result<u8, AppError> {
    let labels = [args.label_a.as_str(), args.label_b.as_str()];
    for l in labels {
        if l.is_empty()
            || !l
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'))
        {
            return Err(AppError::Input(anyhow!(
                "label {l:?}: use letters, digits, '.', '_' or '-' (it names the log files)"
            )));
        }
    }
    if labels[0] == labels[1] {
        return Err(AppError::Input(anyhow!(
            "the two labels are both {:?}: their log files would overwrite each other",
            labels[0]
        )));
    }
    let commands = [args.a.as_str(), args.b.as_str()];
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))
        .map_err(AppError::Output)?;
    let csv_path = args.out.join("interleave.csv");
    let mut runs = Vec::new();
    for k in 0..2 * args.pairs as usize {
        let (side, label, command) = (['A', 'B'][k % 2], labels[k % 2], commands[k % 2]);
        let n = k + 1;
        let log_path = args.out.join(format!("run-{n}-{label}.log"));
        let log = std::fs::File::create(&log_path)
            .with_context(|| format!("creating {}", log_path.display()))
            .map_err(AppError::Output)?;
        let load = load1();
        let (wall_s, text) = run_one(command, log, &log_path).map_err(|e| {
            AppError::Run(anyhow!(
                "run {n} ({side}, {label}): {e:#}; see {}",
                log_path.display()
            ))
        })?;
        let times = step_times(&text);
        let r = Run {
            run: n,
            side,
            wall_s,
            s_per_step: times.first().copied(),
            step_figures: times.len(),
            load1: load,
        };
        dgsph::say!(
            "run {n} {side} {label}: {:.2} s, {} s/step",
            r.wall_s,
            cell(r.s_per_step, 4)
        );
        runs.push(r);
        dgsph::output::write_atomic(&csv_path, csv(&runs, labels).as_bytes())
            .with_context(|| format!("writing {}", csv_path.display()))
            .map_err(AppError::Output)?;
    }
    let md = markdown(&runs, labels, commands);
    let md_path = args.out.join("interleave.md");
    dgsph::output::write_atomic(&md_path, md.as_bytes())
        .with_context(|| format!("writing {}", md_path.display()))
        .map_err(AppError::Output)?;
    dgsph::say!(
        "\n{md}\nwritten: {}, {}",
        csv_path.display(),
        md_path.display()
    );
    Ok(exit::OK)
}

/// Runs `command` through `sh -c` with its output to `file` (at `path`); its wall time and
/// output.
fn run_one(command: &str, file: std::fs::File, path: &Path) -> anyhow::Result<(f64, String)> {
    let err = file
        .try_clone()
        .context("sharing the log between stdout and stderr")?;
    let t0 = Instant::now();
    let status = Command::new("sh")
        .arg("-c")
        .arg(command)
        .stdin(Stdio::null())
        .stdout(file)
        .stderr(err)
        .status()
        .context("starting sh")?;
    let wall = t0.elapsed().as_secs_f64();
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    if !status.success() {
        return Err(anyhow!("the command exited with {status}"));
    }
    Ok((wall, text))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_times_read_the_number_before_each_figure() {
        let text = "  cavity_re100_dg  fluid=10000 iters/step 6.2  0.0185 s/step  5.4e5 \
                    particle-steps/s\n  x 1.5e-2 s/step\nno figure s/step here\n";
        assert_eq!(step_times(text), vec![0.0185, 0.015]);
        assert!(step_times("iters/step 6.2").is_empty());
    }

    #[test]
    fn ratios_are_b_over_a_of_the_means_and_per_pair() {
        let run = |n: usize, side: char, wall: f64, step: Option<f64>| Run {
            run: n,
            side,
            wall_s: wall,
            s_per_step: step,
            step_figures: usize::from(step.is_some()),
            load1: None,
        };
        let runs = [
            run(1, 'A', 1.0, Some(0.01)),
            run(2, 'B', 3.0, Some(0.02)),
            run(3, 'A', 3.0, Some(0.03)),
            run(4, 'B', 3.0, Some(0.04)),
        ];
        // Walls: A mean 2, B mean 3: 1.5; pairs 3.0 and 1.0.
        let (a, b, ratio, range) = ratios(&runs, |r| Some(r.wall_s));
        assert_eq!((ratio.as_str(), range.as_str()), ("1.500", "1.000 – 3.000"));
        assert!(a.starts_with("2.0000 ± 1.4142"), "{a}");
        assert_eq!(b, "3.0000 ± 0.0000");
        // Steps: A 0.02, B 0.03: 1.5; pairs 2 and 4/3.
        let (_, _, ratio, range) = ratios(&runs, |r| r.s_per_step);
        assert_eq!((ratio.as_str(), range.as_str()), ("1.500", "1.333 – 2.000"));
        // A run without a step figure: no step ratio at all, rather than one over fewer runs.
        let mut gap = runs.clone();
        gap[2].s_per_step = None;
        let (a, _, ratio, range) = ratios(&gap, |r| r.s_per_step);
        assert_eq!(
            (a.as_str(), ratio.as_str(), range.as_str()),
            ("—", "—", "—")
        );
    }
}
