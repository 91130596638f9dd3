//! `report.md` and its figures, regenerated from the CSV files a validation (or `run`) wrote.
//!
//! The report reads only what is on disk in the output directory, so `cargo xtask report --out
//! DIR` rebuilds it for any earlier run (a long paper-resolution run in the background, say).
//! Each figure names the paper figure it regenerates:
//!
//! | file | paper | data |
//! |---|---|---|
//! | `fig1_prescribed_volume.svg` | Fig. 1 | `prescribed_*_{euler,pc}.csv` |
//! | `fig3_<case>_volume.svg`, `fig3_<case>_axes.svg` | Fig. 3 | `<drop case>_<scheme>.csv` |
//! | `fig4_<run>_ghia.svg` | Figs. 4–6 | `<run>_<scheme>_profiles.csv` |
//! | `fig7_<run>_density_error.svg` | Figs. 7, 9 | `<run>_<scheme>.csv` (cavity) |
//! | `fig8_<run>_<scheme>_density.svg` | Figs. 8, 10 | last `<run>_<scheme>_density_t*.csv` |

use anyhow::Context;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A CSV file: header names and rows of fields.
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// Reads a CSV file with a header line (no quoting: our files have none).
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
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
        Ok(Self { header, rows })
    }

    /// The numeric values of column `name` (NaN where a field is empty or not a number).
    pub fn column(&self, name: &str) -> Vec<f64> {
        let Some(k) = self.header.iter().position(|h| h == name) else {
            return Vec::new();
        };
        self.rows
            .iter()
            .map(|r| r.get(k).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN))
            .collect()
    }

    /// The text of column `name` in the first row.
    pub fn first(&self, name: &str) -> Option<&str> {
        let k = self.header.iter().position(|h| h == name)?;
        self.rows.first()?.get(k).map(String::as_str)
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
    /// Dashed (exact solutions) — drawn as a thinner line in a lighter shade.
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

const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
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

/// A compact tick label: plain decimals for moderate magnitudes, scientific otherwise.
fn tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (1e-2..1e4).contains(&a) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.2e}")
    }
}

/// Writes a line plot (SVG). `log` plots both axes logarithmically (points ≤ 0 dropped).
/// Returns `false` (and writes nothing) when there is no finite point to plot.
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
    let root = SVGBackend::new(path, (760, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(78);
    if log {
        let mut chart = builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .draw()?;
        draw_series(&mut chart, series, log)?;
    } else {
        let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .y_label_formatter(&|v| tick(*v))
            .draw()?;
        draw_series(&mut chart, series, log)?;
    }
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(true)
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
        let colour = PALETTE[k % PALETTE.len()];
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite() && (!log || (*x > 0.0 && *y > 0.0)))
            .collect();
        if s.markers {
            chart
                .draw_series(
                    pts.iter()
                        .map(move |&p| Cross::new(p, 4, colour.stroke_width(2))),
                )?
                .label(s.label.as_str())
                .legend(move |(x, y)| Cross::new((x + 10, y), 4, colour.stroke_width(2)));
        } else {
            let style = if s.light {
                colour.mix(0.55).stroke_width(1)
            } else {
                colour.stroke_width(2)
            };
            chart
                .draw_series(LineSeries::new(pts, style))?
                .label(s.label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
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
/// symmetric about zero. Returns the colour scale's half-range.
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
    let root = SVGBackend::new(path, (560, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{title}  (colour: ±{vmax:.2e})"),
            ("sans-serif", 16),
        )
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(46)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)?;
    chart.configure_mesh().disable_mesh().draw()?;
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
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(vmax)
}

/// What a CSV file in the output directory holds (told apart by its header).
enum Kind {
    Prescribed,
    Drop,
    Cavity,
    Profiles,
    Density,
    Other,
}

fn kind(table: &Table) -> Kind {
    let h = |k: usize| table.header.get(k).map_or("", String::as_str);
    match (h(0), h(1), h(2), h(3)) {
        ("t", "measure_hull", ..) => Kind::Prescribed,
        ("scheme", "step", "t", "short_step") => Kind::Drop,
        ("scheme", "step", "t", "kinetic_energy") => Kind::Cavity,
        ("profile", "coord", ..) => Kind::Profiles,
        ("x", "y", "z", "density_error") => Kind::Density,
        _ => Kind::Other,
    }
}

/// The CSV files of an output directory, grouped by run name (`<run>_<scheme>...`).
#[derive(Default)]
struct Found {
    /// `prescribed_<dim>` → [(update, table)].
    prescribed: BTreeMap<String, Vec<(String, Table)>>,
    /// drop case → [(scheme, table)].
    drops: BTreeMap<String, Vec<(String, Table)>>,
    /// cavity run → [(scheme, table)].
    cavities: BTreeMap<String, Vec<(String, Table)>>,
    /// cavity run → [(scheme, profiles)].
    profiles: BTreeMap<String, Vec<(String, Table)>>,
    /// (cavity run, scheme) → [(t, snapshot)].
    density: BTreeMap<(String, String), Vec<(f64, PathBuf)>>,
}

const SCHEMES: [&str; 3] = ["euler", "predictor_corrector", "dg"];

/// Splits `<run>_<scheme><rest>` given the scheme names we write.
fn split_scheme<'a>(stem: &'a str, rest: &str) -> Option<(&'a str, &'a str)> {
    let base = stem.strip_suffix(rest)?;
    SCHEMES.iter().chain(&["pc"]).find_map(|s| {
        base.strip_suffix(&format!("_{s}"))
            .map(|run| (run, &base[run.len() + 1..]))
    })
}

fn scan(dir: &Path) -> anyhow::Result<Found> {
    let mut found = Found::default();
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    paths.sort();
    for path in paths {
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        // Snapshot files are many and large: classify them by name, read them when plotted.
        if let Some(k) = stem.find("_density_t") {
            if let (Some((run, scheme)), Ok(t)) = (
                split_scheme(&stem[..k], ""),
                stem[k + "_density_t".len()..].parse::<f64>(),
            ) {
                found
                    .density
                    .entry((run.to_string(), scheme.to_string()))
                    .or_default()
                    .push((t, path.clone()));
            }
            continue;
        }
        let table = Table::read(&path)?;
        match kind(&table) {
            Kind::Prescribed => {
                if let Some((run, update)) = split_scheme(&stem, "") {
                    let dim = if run.contains("ellipsoid") {
                        "3D"
                    } else {
                        "2D"
                    };
                    found
                        .prescribed
                        .entry(dim.to_string())
                        .or_default()
                        .push((update.to_string(), table));
                }
            }
            Kind::Drop | Kind::Cavity => {
                let scheme = table.first("scheme").unwrap_or_default().to_string();
                let Some(run) = stem.strip_suffix(&format!("_{scheme}")) else {
                    continue;
                };
                let map = if matches!(kind(&table), Kind::Drop) {
                    &mut found.drops
                } else {
                    &mut found.cavities
                };
                map.entry(run.to_string())
                    .or_default()
                    .push((scheme, table));
            }
            Kind::Profiles => {
                if let Some((run, scheme)) = split_scheme(&stem, "_profiles") {
                    found
                        .profiles
                        .entry(run.to_string())
                        .or_default()
                        .push((scheme.to_string(), table));
                }
            }
            Kind::Density | Kind::Other => {}
        }
    }
    Ok(found)
}

/// Writes `report.md` and its figures into `dir` from the CSV files there and, if present,
/// `summary.json`. Returns the report's path.
pub fn write(dir: &Path) -> anyhow::Result<PathBuf> {
    let found = scan(dir)?;
    let summary: Option<serde_json::Value> = std::fs::read_to_string(dir.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let mut md = String::from("# dgsph validation report\n\n");
    if let Some(s) = &summary {
        let _ = writeln!(
            md,
            "Preset `{}`, git `{}`, references: {}.\n",
            s["preset"].as_str().unwrap_or("?"),
            s["git"].as_str().unwrap_or("?"),
            s["references"]
                .as_str()
                .unwrap_or("compiled-in cases/reference"),
        );
        checks_table(&mut md, s);
        runs_table(&mut md, s);
    } else {
        md.push_str("No `summary.json` in this directory: figures only.\n\n");
    }
    md += "## Figures\n\nRegenerated from the CSV files in this directory (the paper figure each \
           reproduces is in its heading).\n\n";
    figures(dir, &found, &mut md)?;
    let path = dir.join("report.md");
    std::fs::write(&path, md).with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

fn checks_table(md: &mut String, s: &serde_json::Value) {
    let checks = s["checks"].as_array().cloned().unwrap_or_default();
    let failed = checks
        .iter()
        .filter(|c| c["pass"].as_bool() != Some(true))
        .count();
    let _ = writeln!(
        md,
        "## Checks: {} of {} pass{}\n",
        checks.len() - failed,
        checks.len(),
        if failed > 0 { " — **FAILURES**" } else { "" }
    );
    md.push_str("| case | check | value | reference | tolerance | result | source |\n|---|---|---:|---:|---:|---|---|\n");
    for c in &checks {
        let num = |k: &str| {
            c[k].as_f64()
                .map_or("—".to_string(), |v| format!("{v:.6e}"))
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} |",
            c["case"].as_str().unwrap_or(""),
            c["check"].as_str().unwrap_or(""),
            num("value"),
            num("reference"),
            c["tolerance"]
                .as_f64()
                .map_or("—".into(), |v| format!("{v:.1e}")),
            if c["pass"].as_bool() == Some(true) {
                "pass"
            } else {
                "**FAIL**"
            },
            c["source"].as_str().unwrap_or(""),
        );
    }
    md.push('\n');
}

fn runs_table(md: &mut String, s: &serde_json::Value) {
    let runs = s["runs"].as_array().cloned().unwrap_or_default();
    if runs.is_empty() {
        return;
    }
    md.push_str("## Runs\n\n| case | scheme | kernel | dim | particles | steps | wall (s) | s/step | particle-steps/s | solver iters/step |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n");
    for r in &runs {
        let steps = r["steps"].as_f64().unwrap_or(0.0);
        let wall = r["wall_s"].as_f64().unwrap_or(0.0);
        let n = r["particles"].as_f64().unwrap_or(0.0);
        let per = wall / steps.max(1.0);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {:.2} | {:.3e} | {:.3e} | {:.1} |",
            r["case"].as_str().unwrap_or(""),
            r["scheme"].as_str().unwrap_or(""),
            r["kernel"].as_str().unwrap_or(""),
            r["dim"],
            r["particles"],
            r["steps"],
            wall,
            per,
            if per > 0.0 { n / per } else { 0.0 },
            r["solver_iters_mean"].as_f64().unwrap_or(0.0),
        );
    }
    md.push('\n');
}

fn figure(md: &mut String, file: &str, caption: &str) {
    let _ = writeln!(md, "![{caption}]({file})\n\n*{caption}*\n");
}

/// One line per scheme of `column` against t, written to `file` and linked from `md`.
#[allow(clippy::too_many_arguments)]
fn per_scheme_figure(
    dir: &Path,
    md: &mut String,
    runs: &[(String, Table)],
    column: &str,
    file: &str,
    title: &str,
    y_label: &str,
    caption: &str,
) -> anyhow::Result<()> {
    let series: Vec<Series> = runs
        .iter()
        .map(|(s, t)| Series::line(s.as_str(), t.pairs("t", column)))
        .collect();
    if line_plot(&dir.join(file), title, "t", y_label, &series, false)? {
        figure(md, file, caption);
    }
    Ok(())
}

fn figures(dir: &Path, found: &Found, md: &mut String) -> anyhow::Result<()> {
    // Fig. 1: volume under a prescribed divergence-free field.
    let mut series = Vec::new();
    for (dim, runs) in &found.prescribed {
        for (update, t) in runs {
            let hull = t.column("measure_hull");
            let v0 = hull.first().copied().unwrap_or(f64::NAN);
            let pts = t
                .column("t")
                .into_iter()
                .zip(hull)
                .map(|(x, v)| (x, v / v0))
                .collect();
            series.push(Series::line(format!("{dim} {update}"), pts));
        }
    }
    if line_plot(
        &dir.join("fig1_prescribed_volume.svg"),
        "Prescribed field: volume V(t)/V(0) (convex hull)",
        "t",
        "V/V0",
        &series,
        false,
    )? {
        md.push_str("### Fig. 1 — volume under a prescribed divergence-free field\n\n");
        figure(
            md,
            "fig1_prescribed_volume.svg",
            "Euler loses volume linearly in t; PC keeps it to O(Δt²).",
        );
    }
    // Fig. 3: drops.
    for (case, runs) in &found.drops {
        let _ = write!(md, "### Fig. 3 — {case}\n\n");
        per_scheme_figure(
            dir,
            md,
            runs,
            "rel_change_moments",
            &format!("fig3_{case}_volume.svg"),
            &format!("{case}: relative volume change"),
            "ΔV/V0 (second moments)",
            "Relative volume change against time, per scheme.",
        )?;
        let mut axes = Vec::new();
        for (s, t) in runs {
            axes.push(Series::line(format!("{s} a"), t.pairs("t", "a")));
            axes.push(Series::line(format!("{s} b"), t.pairs("t", "b")));
        }
        if let Some((_, t)) = runs.first() {
            axes.push(Series::exact("exact a", t.pairs("t", "a_exact")));
            axes.push(Series::exact("exact b", t.pairs("t", "b_exact")));
        }
        let f = format!("fig3_{case}_axes.svg");
        if line_plot(
            &dir.join(&f),
            &format!("{case}: semi-axes"),
            "t",
            "semi-axis",
            &axes,
            false,
        )? {
            figure(
                md,
                &f,
                "Semi-axes a (stretched) and b against the exact solution.",
            );
        }
    }
    // Figs. 4–6: Ghia profiles.
    for (run, profs) in &found.profiles {
        let _ = write!(
            md,
            "### Figs. 4–6 — {run}: centreline velocity against Ghia et al. (1982)\n\n"
        );
        for (profile, coord, value) in [
            ("u_vertical", "y", "u(0.5, y)"),
            ("v_horizontal", "x", "v(x, 0.5)"),
        ] {
            let mut series = Vec::new();
            for (scheme, t) in profs {
                let rows: Vec<(f64, f64)> = t
                    .rows
                    .iter()
                    .filter(|r| r[0] == profile)
                    .filter_map(|r| Some((r[1].parse().ok()?, r[2].parse().ok()?)))
                    .collect();
                series.push(Series::line(scheme.as_str(), rows));
            }
            if let Some((_, t)) = profs.first() {
                let ghia: Vec<(f64, f64)> = t
                    .rows
                    .iter()
                    .filter(|r| r[0] == profile)
                    .filter_map(|r| Some((r[1].parse().ok()?, r[3].parse().ok()?)))
                    .filter(|(_, g): &(f64, f64)| g.is_finite())
                    .collect();
                series.push(Series::markers("Ghia et al.", ghia));
            }
            let f = format!("fig4_{run}_{profile}.svg");
            if line_plot(
                &dir.join(&f),
                &format!("{run}: {value}"),
                coord,
                value,
                &series,
                false,
            )? {
                figure(
                    md,
                    &f,
                    &format!("{value} at the end time, per scheme; crosses: Ghia et al."),
                );
            }
        }
    }
    // Figs. 7 and 9: RMS density error; Figs. 8 and 10: density-error field.
    for (run, tables) in &found.cavities {
        let _ = write!(md, "### Figs. 7/9 — {run}: RMS density error (Eq. 31)\n\n");
        per_scheme_figure(
            dir,
            md,
            tables,
            "density_error_rms",
            &format!("fig7_{run}_density_error.svg"),
            &format!("{run}: RMS of ρ̂/ρ0 − 1"),
            "RMS density error",
            "RMS relative density error on the uniform probe array against time.",
        )?;
        let ghia: Vec<Series> = tables
            .iter()
            .flat_map(|(s, t)| {
                [
                    Series::line(format!("{s} u rms"), t.pairs("t", "ghia_u_rms")),
                    Series::line(format!("{s} v rms"), t.pairs("t", "ghia_v_rms")),
                ]
            })
            .filter(|s| !s.points.is_empty())
            .collect();
        let f = format!("fig_{run}_ghia_history.svg");
        if !ghia.is_empty()
            && line_plot(
                &dir.join(&f),
                &format!("{run}: RMS deviation from Ghia against time"),
                "t",
                "RMS deviation",
                &ghia,
                false,
            )?
        {
            figure(
                md,
                &f,
                "How the centreline profiles settle: RMS deviation from Ghia et al. against time.",
            );
        }
        for (scheme, _) in tables {
            let Some(snaps) = found.density.get(&(run.clone(), scheme.clone())) else {
                continue;
            };
            let Some((t, path)) = snaps.iter().max_by(|a, b| a.0.total_cmp(&b.0)) else {
                continue;
            };
            let snap = Table::read(path)?;
            let samples: Vec<(f64, f64, f64)> = snap
                .column("x")
                .into_iter()
                .zip(snap.column("y"))
                .zip(snap.column("density_error"))
                .map(|((x, y), e)| (x, y, e))
                .collect();
            let n = (samples.len() as f64).sqrt().round().max(1.0);
            let f = format!("fig8_{run}_{scheme}_density.svg");
            heat_map(
                &dir.join(&f),
                &format!("{run} {scheme}: ρ̂/ρ0 − 1 at t = {t}"),
                &samples,
                1.0 / n,
            )?;
            figure(
                md,
                &f,
                &format!("Density-error field of {scheme} at t = {t} (Figs. 8, 10)."),
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scheme_suffixes_split_and_tables_classify() {
        assert_eq!(
            split_scheme("cavity_re100_predictor_corrector_profiles", "_profiles"),
            Some(("cavity_re100", "predictor_corrector"))
        );
        assert_eq!(
            split_scheme("prescribed_ellipse_pc", ""),
            Some(("prescribed_ellipse", "pc"))
        );
        assert_eq!(split_scheme("no_scheme_here", ""), None);
        let t = Table {
            header: "profile,coord,value,ghia"
                .split(',')
                .map(String::from)
                .collect(),
            rows: vec![vec![
                "u_vertical".into(),
                "0.5".into(),
                "-0.2".into(),
                "nan".into(),
            ]],
        };
        assert!(matches!(kind(&t), Kind::Profiles));
        assert_eq!(t.column("value"), vec![-0.2]);
        assert!(t.column("ghia")[0].is_nan());
    }

    #[test]
    fn diverging_colours_end_in_blue_and_red_through_white() {
        assert_eq!(diverging(0.0), RGBColor(255, 255, 255));
        assert_eq!(diverging(1.0), RGBColor(180, 20, 30));
        assert_eq!(diverging(-2.0), RGBColor(20, 60, 170));
    }
}
