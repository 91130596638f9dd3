//! `report.md` and its figures, regenerated from what a validation or run wrote to an output
//! directory: the typed `summary.json` (if any), each run's `<run>.run.json`, its record CSV and
//! its table CSVs. Which figures a run gets is its case's ([`registry::figures`]), drawn from
//! column names, so `dgsph report DIR` rebuilds the report for any earlier run.
//!
//! Figures are SVG: line plots with the legend beside the plot area (never on the data), heat
//! maps with a colour bar and axis labels (3D fields sliced at mid-depth), and log axes with
//! tick labels rounded to three significant digits.

use crate::summary::{RunRecord, Summary};
use anyhow::Context;
use plotters::prelude::*;
use sph_cases::figures::{Figure, SeriesStyle};
use sph_cases::{CaseKind, registry};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A CSV file: header names and rows of fields (rows may be short: missing fields read as NaN).
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// Reads a CSV file with a header line (no quoting: our files have none).
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        Ok(Self::parse(&text))
    }

    /// Parses CSV text.
    pub fn parse(text: &str) -> Self {
        let mut lines = text.lines();
        let header = lines
            .next()
            .unwrap_or_default()
            .split(',')
            .map(str::to_string)
            .collect();
        let rows = lines
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect();
        Self { header, rows }
    }

    /// The numeric values of column `name` (NaN where a field is missing, empty or not a
    /// number); empty if there is no such column.
    pub fn column(&self, name: &str) -> Vec<f64> {
        let Some(k) = self.header.iter().position(|h| h == name) else {
            return Vec::new();
        };
        self.rows
            .iter()
            .map(|r| r.get(k).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN))
            .collect()
    }

    fn pairs(&self, x: &str, y: &str) -> Vec<(f64, f64)> {
        self.column(x)
            .into_iter()
            .zip(self.column(y))
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .collect()
    }
}

/// One curve of a line plot.
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Data points.
    pub points: Vec<(f64, f64)>,
    /// Markers only (reference data) instead of a line.
    pub markers: bool,
    /// A thin light line (exact solutions).
    pub light: bool,
}

impl Series {
    /// A solid line.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            markers: false,
            light: false,
        }
    }

    /// Markers (reference points).
    pub fn markers(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            markers: true,
            ..Self::line(label, points)
        }
    }

    /// A thin light line (exact solution).
    pub fn exact(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            light: true,
            ..Self::line(label, points)
        }
    }
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

fn bounds(series: &[Series], log: bool) -> Option<((f64, f64), (f64, f64))> {
    let pts = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite() && (!log || (*x > 0.0 && *y > 0.0)));
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let mut any = false;
    for &(x, y) in pts {
        any = true;
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !any {
        return None;
    }
    let pad = |a: f64, b: f64| {
        if log {
            (a / 1.25, b * 1.25)
        } else {
            let d = if b > a {
                0.05 * (b - a)
            } else {
                a.abs().max(1e-12) * 0.05
            };
            (a - d, b + d)
        }
    };
    Some((pad(x0, x1), pad(y0, y1)))
}

/// A compact tick label with at most three significant digits: plain decimals for moderate
/// magnitudes, scientific otherwise (`0.0010000000000001` prints as `0.001`).
pub fn tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || !v.is_finite() {
        return "0".into();
    }
    if (1e-3..1e4).contains(&a) {
        let digits = (2 - a.log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = if m.contains('.') {
            m.trim_end_matches('0').trim_end_matches('.')
        } else {
            m
        };
        format!("{m}e{e}")
    }
}

/// Writes a line plot (SVG) with the legend in a column right of the plot. `log` plots both
/// axes logarithmically (points ≤ 0 dropped). Returns `false` (and writes nothing) when there
/// is no finite point to plot.
pub fn line_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log: bool,
) -> anyhow::Result<bool> {
    let Some(((x0, x1), (y0, y1))) = bounds(series, log) else {
        return Ok(false);
    };
    let root = SVGBackend::new(path, (900, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let (plot, legend) = root.split_horizontally(660);
    let mut builder = ChartBuilder::on(&plot);
    builder
        .caption(title, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(78);
    if log {
        let mut chart = builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()?;
        draw_series(&mut chart, series, log)?;
    } else {
        let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()?;
        draw_series(&mut chart, series, log)?;
    }
    draw_legend(&legend, series)?;
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(true)
}

fn style(k: usize, s: &Series) -> (RGBColor, ShapeStyle) {
    let colour = PALETTE[k % PALETTE.len()];
    let style = if s.light {
        colour.mix(0.55).stroke_width(1)
    } else {
        colour.stroke_width(2)
    };
    (colour, style)
}

fn draw_series<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    series: &[Series],
    log: bool,
) -> anyhow::Result<()>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    for (k, s) in series.iter().enumerate() {
        let (colour, style) = style(k, s);
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite() && (!log || (*x > 0.0 && *y > 0.0)))
            .collect();
        if s.markers {
            chart.draw_series(
                pts.iter()
                    .map(move |&p| Cross::new(p, 4, colour.stroke_width(2))),
            )?;
        } else {
            chart.draw_series(LineSeries::new(pts, style))?;
        }
    }
    Ok(())
}

fn draw_legend(
    area: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    series: &[Series],
) -> anyhow::Result<()> {
    for (k, s) in series.iter().enumerate() {
        let (colour, style) = style(k, s);
        let y = 50 + 22 * k as i32;
        if s.markers {
            area.draw(&Cross::new((14, y), 4, colour.stroke_width(2)))?;
        } else {
            area.draw(&PathElement::new(vec![(4, y), (26, y)], style))?;
        }
        area.draw(&Text::new(
            s.label.clone(),
            (34, y - 7),
            ("sans-serif", 13).into_font(),
        ))?;
    }
    Ok(())
}

/// A diverging blue–white–red colour for `v ∈ [−1, 1]`.
fn diverging(v: f64) -> RGBColor {
    let v = v.clamp(-1.0, 1.0);
    let mix = |a: u8, t: f64| (255.0 + (a as f64 - 255.0) * t).round() as u8;
    if v >= 0.0 {
        RGBColor(mix(180, v), mix(20, v), mix(30, v))
    } else {
        RGBColor(mix(20, -v), mix(60, -v), mix(170, -v))
    }
}

/// Writes a colour map of `(x, y, value)` samples on a uniform grid of spacing `cell` (SVG),
/// symmetric about zero, with axis labels and a colour bar. Returns the colour scale's
/// half-range.
pub fn heat_map(
    path: &Path,
    title: &str,
    samples: &[(f64, f64, f64)],
    cell: f64,
) -> anyhow::Result<f64> {
    let vmax = samples
        .iter()
        .map(|s| s.2.abs())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-300);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for s in samples {
        x0 = x0.min(s.0 - 0.5 * cell);
        x1 = x1.max(s.0 + 0.5 * cell);
        y0 = y0.min(s.1 - 0.5 * cell);
        y1 = y1.max(s.1 + 0.5 * cell);
    }
    if samples.is_empty() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let root = SVGBackend::new(path, (680, 540)).into_drawing_area();
    root.fill(&WHITE)?;
    let (plot, bar) = root.split_horizontally(560);
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x")
        .y_desc("y")
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    let h = 0.5 * cell;
    chart.draw_series(
        samples
            .iter()
            .filter(|s| s.2.is_finite())
            .map(|&(x, y, v)| {
                Rectangle::new(
                    [(x - h, y - h), (x + h, y + h)],
                    diverging(v / vmax).filled(),
                )
            }),
    )?;
    // Colour bar: −vmax (bottom) to +vmax (top).
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(40)
        .margin_bottom(52)
        .margin_right(6)
        .y_label_area_size(62)
        .build_cartesian_2d(0.0..1.0, -vmax..vmax)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_label_formatter(&|v| tick(*v))
        .y_labels(5)
        .draw()?;
    let steps = 64;
    cb.draw_series((0..steps).map(|k| {
        let a = -vmax + 2.0 * vmax * k as f64 / steps as f64;
        let b = a + 2.0 * vmax / steps as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            diverging((a + b) / (2.0 * vmax)).filled(),
        )
    }))?;
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(vmax)
}

/// The runs of an output directory (from their `.run.json`), grouped by run name, in name order.
fn scan(dir: &Path) -> anyhow::Result<BTreeMap<String, Vec<RunRecord>>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(".run.json"))
        .collect();
    paths.sort();
    let mut out: BTreeMap<String, Vec<RunRecord>> = BTreeMap::new();
    for p in paths {
        let text =
            std::fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))?;
        match serde_json::from_str::<RunRecord>(&text) {
            Ok(r) => out.entry(r.name.clone()).or_default().push(r),
            Err(e) => crate::warn!("report: skipping {}: {e}", p.display()),
        }
    }
    for runs in out.values_mut() {
        let order = |s: &str| match s {
            "euler" => 0,
            "predictor_corrector" => 1,
            "dg" => 2,
            _ => 3,
        };
        runs.sort_by_key(|r| order(&r.scheme));
    }
    Ok(out)
}

fn case_kind(name: &str) -> Option<CaseKind> {
    CaseKind::ALL.into_iter().find(|k| k.name() == name)
}

/// Writes `report.md` and its figures into `dir` from what is there. Returns the report's path.
pub fn write(dir: &Path) -> anyhow::Result<PathBuf> {
    let runs = scan(dir)?;
    let summary: Option<Summary> = match std::fs::read_to_string(dir.join("summary.json")) {
        Ok(t) => Some(serde_json::from_str(&t).context("summary.json does not match its schema")?),
        Err(_) => None,
    };
    if runs.is_empty() && summary.is_none() {
        anyhow::bail!(
            "{} holds no run to report: no readable <run>.run.json and no summary.json (the \
             output directory of `dgsph run` or `cargo xtask validate`)",
            dir.display()
        );
    }
    let mut md = String::from("# dgsph report\n\n");
    if let Some(s) = &summary {
        let _ = writeln!(
            md,
            "Preset `{}`, suite `{}`, git `{}`, references: {}, {:.0} s.\n",
            s.preset, s.suite, s.git, s.references, s.wall_s
        );
        checks_table(&mut md, s);
    }
    let all: Vec<&RunRecord> = runs.values().flatten().collect();
    stability_table(&mut md, &all);
    runs_table(&mut md, &all);
    md += "## Figures\n\nRegenerated from the CSV files in this directory.\n\n";
    for (name, group) in &runs {
        figures(dir, name, group, &mut md)?;
    }
    let path = dir.join("report.md");
    crate::output::write_atomic(&path, md.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

fn checks_table(md: &mut String, s: &Summary) {
    let failed = s
        .checks
        .iter()
        .filter(|c| !c.pass && c.known_failure.is_none())
        .count();
    let known = s
        .checks
        .iter()
        .filter(|c| !c.pass && c.known_failure.is_some())
        .count();
    let _ = writeln!(
        md,
        "## Checks: {} of {} pass{}{}\n",
        s.checks.iter().filter(|c| c.pass).count(),
        s.checks.len(),
        if known > 0 {
            format!(", {known} known failures (declared in their scenes, reasons below)")
        } else {
            String::new()
        },
        if failed > 0 { " — **FAILURES**" } else { "" }
    );
    md.push_str(
        "| case | check | value | criterion | result | source |\n|---|---|---:|---|---|---|\n",
    );
    for c in &s.checks {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            c.case,
            c.check,
            c.value.map_or("—".to_string(), |v| format!("{v:.6e}")),
            c.criterion.describe(),
            match (c.pass, &c.known_failure) {
                (true, None) => "pass".to_string(),
                (false, None) => "**FAIL**".to_string(),
                (false, Some(why)) => format!("known failure: {why}"),
                (true, Some(_)) => "pass (a declared known failure passed)".to_string(),
            },
            c.source,
        );
    }
    md.push('\n');
}

fn runs_table(md: &mut String, runs: &[&RunRecord]) {
    if runs.is_empty() {
        return;
    }
    md.push_str("## Runs\n\n| run | case | scheme | kernel | dim | particles | steps | t | wall (s) | s/step | particle-steps/s | solver iters/step | status |\n|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n");
    for r in runs {
        let per = r.wall_s / r.steps.max(1) as f64;
        let n = (r.fluid + r.walls) as f64;
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {:.4} | {:.2} | {:.3e} | {:.3e} | {:.1} | {} |",
            r.name,
            r.case,
            r.scheme,
            r.kernel,
            r.dim,
            r.fluid + r.walls,
            r.steps,
            r.t,
            r.wall_s,
            per,
            if per > 0.0 { n / per } else { 0.0 },
            r.solver_iters_mean,
            r.status.replace('|', "/"),
        );
    }
    md.push('\n');
}

/// Case × scheme: how far each run got and how well it held together.
fn stability_table(md: &mut String, runs: &[&RunRecord]) {
    if runs.is_empty() {
        return;
    }
    md.push_str(
        "## Stability

Reached t and step; max interior density error \
         (|ρ̂/ρ̂_lattice − 1|, interior: no free-surface particle in the support); volume change \
         (drops: max |ΔV/V₀|, second moments); max |u|/U (U: initial largest speed, √(gH) for \
         water at rest, the lid speed for cavities); penetrations; solver iterations per step; \
         wall time.\n\n| run | scheme | reached t | step | density error | volume change | \
         max \\|u\\|/U | penetrations | iters/step | wall (s) | status |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n",
    );
    let fmt = |r: &RunRecord, k: &str| {
        r.results
            .get(k)
            .copied()
            .flatten()
            .map_or("—".to_string(), |v| format!("{v:.3e}"))
    };
    for r in runs {
        let _ = writeln!(
            md,
            "| {} | {} | {:.4} | {} | {} | {} | {} | {} | {:.1} | {:.1} | {} |",
            r.name,
            r.scheme,
            r.t,
            r.step,
            fmt(r, "density_error_max"),
            fmt(r, "volume_change_max"),
            fmt(r, "max_speed_ratio"),
            r.results
                .get("max_wall_penetrations")
                .copied()
                .flatten()
                .map_or("—".to_string(), |v| format!("{v:.0}")),
            r.solver_iters_mean,
            r.wall_s,
            if r.status == "completed" {
                "completed".to_string()
            } else {
                r.status
                    .split(';')
                    .next()
                    .unwrap_or("")
                    .chars()
                    .take(80)
                    .collect::<String>()
                    .replace('|', "/")
            },
        );
    }
    md.push('\n');
}

fn figure(md: &mut String, file: &str, caption: &str) {
    let _ = writeln!(md, "![{caption}]({file})\n\n*{caption}*\n");
}

/// The tables `<run>_<prefix>*.csv` of a run, with the suffix parsed as a time.
fn tables_with_prefix(dir: &Path, run: &str, prefix: &str) -> Vec<(f64, PathBuf)> {
    let start = format!("{run}_{prefix}");
    let mut found: Vec<(f64, PathBuf)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let t = name
                .strip_prefix(&start)?
                .strip_suffix(".csv")?
                .parse()
                .ok()?;
            Some((t, e.path()))
        })
        .collect();
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    found
}

fn figures(dir: &Path, name: &str, runs: &[RunRecord], md: &mut String) -> anyhow::Result<()> {
    let Some(first) = runs.first() else {
        return Ok(());
    };
    let Some(kind) = case_kind(&first.case) else {
        return Ok(());
    };
    let _ = write!(md, "### {name} ({})\n\n", first.case);
    for fig in registry::figures(kind, first.dim) {
        match fig {
            Figure::Lines {
                name: fname,
                title,
                table,
                x,
                y_label,
                series,
            } => {
                let mut out = Vec::new();
                for (k, r) in runs.iter().enumerate() {
                    let run = format!("{}_{}", r.name, r.scheme);
                    let file = match table {
                        Some(t) => dir.join(format!("{run}_{t}.csv")),
                        None => dir.join(format!("{run}.csv")),
                    };
                    let Ok(t) = Table::read(&file) else { continue };
                    for s in &series {
                        match s.style {
                            SeriesStyle::PerScheme => out.push(Series::line(
                                if series
                                    .iter()
                                    .filter(|q| q.style == SeriesStyle::PerScheme)
                                    .count()
                                    > 1
                                {
                                    format!("{} {}", r.scheme, s.column)
                                } else {
                                    r.scheme.clone()
                                },
                                t.pairs(x, s.column),
                            )),
                            SeriesStyle::Exact if k == 0 => out.push(Series::exact(
                                format!("exact {}", s.column),
                                t.pairs(x, s.column),
                            )),
                            SeriesStyle::Reference if k == 0 => {
                                out.push(Series::markers(s.label, t.pairs(x, s.column)))
                            }
                            _ => {}
                        }
                    }
                }
                let file = format!("{name}_{fname}.svg");
                if line_plot(
                    &dir.join(&file),
                    &format!("{name}: {title}"),
                    x,
                    y_label,
                    &out,
                    false,
                )? {
                    figure(md, &file, &format!("{name}: {title}"));
                }
            }
            Figure::HeatMap {
                name: fname,
                title,
                table_prefix,
                value,
            } => {
                for r in runs {
                    let run = format!("{}_{}", r.name, r.scheme);
                    let Some((t, path)) = tables_with_prefix(dir, &run, table_prefix).pop() else {
                        continue;
                    };
                    let tab = Table::read(&path)?;
                    let (xs, ys, zs, vs) = (
                        tab.column("x"),
                        tab.column("y"),
                        tab.column("z"),
                        tab.column(value),
                    );
                    let mut samples: Vec<(f64, f64, f64, f64)> = xs
                        .iter()
                        .zip(&ys)
                        .zip(&vs)
                        .enumerate()
                        .map(|(i, ((x, y), v))| (*x, *y, zs.get(i).copied().unwrap_or(0.0), *v))
                        .collect();
                    // 3D: the slice at mid-depth (the z layer nearest the middle of the range).
                    let mut slice = String::new();
                    if r.dim == 3 && !samples.is_empty() {
                        let (zlo, zhi) = samples
                            .iter()
                            .fold((f64::MAX, f64::MIN), |(a, b), s| (a.min(s.2), b.max(s.2)));
                        let mid = 0.5 * (zlo + zhi);
                        let zc = samples
                            .iter()
                            .map(|s| s.2)
                            .min_by(|a, b| (a - mid).abs().total_cmp(&(b - mid).abs()))
                            .unwrap_or(mid);
                        samples.retain(|s| (s.2 - zc).abs() < 1e-9);
                        slice = format!(", slice z = {zc:.3}");
                    }
                    let flat: Vec<(f64, f64, f64)> =
                        samples.iter().map(|s| (s.0, s.1, s.3)).collect();
                    let n = (flat.len() as f64).sqrt().round().max(1.0);
                    let xr = flat.iter().map(|s| s.0).fold(f64::MIN, f64::max)
                        - flat.iter().map(|s| s.0).fold(f64::MAX, f64::min);
                    let cell = if n > 1.0 { xr / (n - 1.0) } else { 1.0 };
                    let file = format!("{run}_{fname}.svg");
                    heat_map(
                        &dir.join(&file),
                        &format!("{run}: {title} at t = {t}{slice}"),
                        &flat,
                        cell,
                    )?;
                    figure(md, &file, &format!("{run}: {title} at t = {t}{slice}"));
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_rows_read_as_missing_values() {
        // A profile file whose last row was cut off (a killed run): no panic, NaN where missing.
        let t = Table::parse("y,u,u_ghia\n0.1,0.2,0.3\n0.5,0.4\n0.9");
        assert_eq!(t.column("u").len(), 3);
        assert!(t.column("u_ghia")[1].is_nan() && t.column("u")[2].is_nan());
        assert!(t.column("nope").is_empty());
        assert_eq!(t.pairs("y", "u_ghia"), vec![(0.1, 0.3)]);
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(0.0010000000000001), "0.001");
        assert_eq!(tick(0.01), "0.01");
        assert_eq!(tick(123.456), "123");
        assert_eq!(tick(1.5), "1.5");
        assert_eq!(tick(1e-5), "1e-5");
        assert_eq!(tick(2.5e6), "2.5e6");
        assert_eq!(tick(-0.25), "-0.25");
    }

    #[test]
    fn diverging_colours_end_in_blue_and_red_through_white() {
        assert_eq!(diverging(0.0), RGBColor(255, 255, 255));
        assert_eq!(diverging(1.0), RGBColor(180, 20, 30));
        assert_eq!(diverging(-2.0), RGBColor(20, 60, 170));
    }
}
