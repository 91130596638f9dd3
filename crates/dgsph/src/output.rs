//! The files of one scheme's run, written as the run produces them ([`RunFiles`], a
//! [`RunSink`]):
//!
//! | file | content |
//! |---|---|
//! | `<run>.csv` | the records: one row per record, a column per [`Column`] (empty: no value) |
//! | `<run>.mcap` | the records as JSON on `/metrics` and particle frames on `/particles` |
//! | `<run>_<table>.csv` | the case's tables (density snapshots, profiles) |
//! | `<run>.checkpoint` | the state to resume from (binary, checksummed) |
//! | `<run>.pvd`, `<run>_vtk/` | ParaView frames, when asked for |
//!
//! with `<run> = <name>_<scheme>`. Every row is flushed as it is written and every MCAP record
//! ends its chunk, so a failed or killed run keeps everything written before.

use crate::mcap_sink::McapSink;
use crate::vtk::VtkSeries;
use anyhow::Context;
use sph_cases::run::RunSink;
use sph_cases::{Column, Table};
use sph_integrators::{Checkpoint, Frame};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Formats a value for CSV: Rust's shortest round-trip representation, empty for NaN.
pub fn csv_value(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else {
        format!("{v}")
    }
}

/// How a run reports progress on stderr.
pub struct Progress {
    label: String,
    bar: Option<indicatif::ProgressBar>,
    last_line: Instant,
    started: Instant,
    every: Duration,
}

/// Resolution of the progress bar.
const TICKS: u64 = 1000;

impl Progress {
    /// A bar when stderr is a terminal; otherwise a line every `every` (none for zero).
    pub fn new(label: String, every: Duration) -> Self {
        use std::io::IsTerminal;
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = indicatif::ProgressBar::new(TICKS);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "  {prefix:<32} [{bar:30}] {msg:<14} {elapsed_precise} (eta {eta})",
                )
                .expect("static template")
                .progress_chars("=> "),
            );
            bar.set_prefix(label.clone());
            bar
        });
        Self {
            label,
            bar,
            last_line: Instant::now(),
            started: Instant::now(),
            every,
        }
    }

    /// Reports step `step` at time `t` of `t_end`.
    pub fn update(&mut self, step: usize, t: f64, t_end: f64) {
        let frac = (t / t_end).clamp(0.0, 1.0);
        if let Some(bar) = &self.bar {
            bar.set_position((frac * TICKS as f64).round() as u64);
            bar.set_message(format!("t = {t:.4}"));
        } else if !self.every.is_zero() && self.last_line.elapsed() >= self.every {
            self.last_line = Instant::now();
            let elapsed = self.started.elapsed().as_secs_f64();
            let eta = if frac > 0.0 {
                format!("{:.0} s", elapsed * (1.0 - frac) / frac)
            } else {
                "?".into()
            };
            crate::warn!(
                "  {}: step {step}, t = {t:.6} of {t_end} ({:.1} %), {elapsed:.0} s, ETA {eta}",
                self.label,
                100.0 * frac
            );
        }
    }

    /// Removes the bar.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }
}

/// Options of a run's files.
#[derive(Clone, Debug, Default)]
pub struct FileOptions {
    /// Continue the files of a run resumed from the checkpoint of this step.
    pub resume_step: Option<usize>,
    /// Write ParaView frames.
    pub vtk: bool,
    /// Seconds between progress lines when stderr is not a terminal (0: none).
    pub progress_every: f64,
    /// Metadata stored in the MCAP file.
    pub metadata: BTreeMap<String, String>,
}

/// The files of one scheme's run (see the module docs).
pub struct RunFiles {
    out: PathBuf,
    run: String,
    options: FileOptions,
    csv_path: PathBuf,
    csv: Option<std::io::BufWriter<std::fs::File>>,
    columns: Vec<String>,
    mcap: Option<McapSink>,
    vtk: Option<VtkSeries>,
    progress: Progress,
    checkpoint_path: PathBuf,
    step_column: usize,
}

impl RunFiles {
    /// The files of run `run` (`<name>_<scheme>`) in `out`.
    pub fn new(out: &Path, run: &str, options: FileOptions) -> Self {
        Self {
            out: out.to_path_buf(),
            run: run.to_string(),
            csv_path: out.join(format!("{run}.csv")),
            csv: None,
            columns: Vec::new(),
            mcap: None,
            vtk: None,
            progress: Progress::new(
                run.to_string(),
                Duration::from_secs_f64(options.progress_every.max(0.0)),
            ),
            checkpoint_path: checkpoint_path(out, run),
            step_column: 0,
            options,
        }
    }

    /// The CSV time series.
    pub fn csv_path(&self) -> &Path {
        &self.csv_path
    }

    /// Finishes the MCAP file and the progress display (also done on drop).
    pub fn finish(&mut self) -> anyhow::Result<()> {
        self.progress.finish();
        if let Some(m) = self.mcap.as_mut() {
            m.finish()?;
        }
        Ok(())
    }

    fn open(&mut self, columns: &[Column]) -> anyhow::Result<()> {
        self.columns = columns.iter().map(|c| c.name.clone()).collect();
        self.step_column = self.columns.iter().position(|c| c == "step").unwrap_or(0);
        let header = self.columns.join(",");
        let continuing = self.options.resume_step.is_some() && self.csv_path.exists();
        if let (true, Some(step)) = (continuing, self.options.resume_step) {
            truncate_csv_after_step(&self.csv_path, &header, step)?;
        }
        let file = std::fs::OpenOptions::new()
            .create(true)
            .write(true)
            .append(continuing)
            .truncate(!continuing)
            .open(&self.csv_path)
            .with_context(|| format!("creating {}", self.csv_path.display()))?;
        let mut csv = std::io::BufWriter::new(file);
        if !continuing {
            writeln!(csv, "{header}")?;
            csv.flush()?;
        }
        self.csv = Some(csv);
        let mcap_name = match self.options.resume_step {
            Some(step) => format!("{}_from_step{step}.mcap", self.run),
            None => format!("{}.mcap", self.run),
        };
        self.mcap = Some(McapSink::create(
            &self.out.join(mcap_name),
            self.options.metadata.clone(),
        )?);
        if self.options.vtk {
            self.vtk = Some(VtkSeries::create(
                &self.out,
                &self.run,
                self.options.resume_step,
            )?);
        }
        Ok(())
    }
}

impl Drop for RunFiles {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

fn io_error(e: anyhow::Error) -> std::io::Error {
    std::io::Error::other(format!("{e:#}"))
}

impl RunSink for RunFiles {
    fn begin(&mut self, columns: &[Column]) -> std::io::Result<()> {
        self.open(columns).map_err(io_error)
    }

    fn record(
        &mut self,
        values: &[f64],
        frame: &dyn Frame,
        frame_due: bool,
    ) -> std::io::Result<()> {
        let row: Vec<String> = values.iter().map(|v| csv_value(*v)).collect();
        if let Some(csv) = self.csv.as_mut() {
            writeln!(csv, "{}", row.join(","))?;
            csv.flush()?;
        }
        let metrics: serde_json::Map<String, serde_json::Value> = self
            .columns
            .iter()
            .zip(values)
            .map(|(k, v)| {
                let v =
                    serde_json::Number::from_f64(*v).map_or(serde_json::Value::Null, Into::into);
                (k.clone(), v)
            })
            .collect();
        if let Some(m) = self.mcap.as_mut() {
            m.record(frame, &serde_json::Value::Object(metrics), frame_due)
                .map_err(io_error)?;
        }
        if frame_due && let Some(v) = self.vtk.as_mut() {
            let step = values.get(self.step_column).copied().unwrap_or(0.0) as usize;
            v.write(frame, step).map_err(io_error)?;
        }
        Ok(())
    }

    fn table(&mut self, table: &Table) -> std::io::Result<()> {
        let path = self.out.join(format!("{}_{}.csv", self.run, table.name));
        // Streamed: a field at every particle of a large run is not first built as one string.
        write_atomic_with(&path, |w| {
            writeln!(w, "{}", table.columns.join(","))?;
            for r in table.rows() {
                for (k, v) in r.iter().enumerate() {
                    if k > 0 {
                        w.write_all(b",")?;
                    }
                    w.write_all(csv_value(*v).as_bytes())?;
                }
                w.write_all(b"\n")?;
            }
            Ok(())
        })
    }

    fn checkpoint(&mut self, checkpoint: &Checkpoint) -> std::io::Result<()> {
        write_atomic(&self.checkpoint_path, &checkpoint.encode())
    }

    fn progress(&mut self, step: usize, t: f64, t_end: f64) {
        self.progress.update(step, t, t_end);
    }
}

/// `<out>/<run>.checkpoint`.
pub fn checkpoint_path(out: &Path, run: &str) -> PathBuf {
    out.join(format!("{run}.checkpoint"))
}

/// Writes `bytes` to a temporary file beside `path` and renames it over `path`, so a reader
/// (or a run killed mid-write) sees the old file or the new one, never a torn one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// [`write_atomic`] with the contents written by `write` through a buffer.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        write(&mut w)?;
        let f = w.into_inner().map_err(|e| e.into_error())?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path)
}

/// Rewrites the CSV at `path` without its data rows whose `step` column exceeds `step`
/// (atomically). A CSV whose header is not `header` (written by another version, with other
/// columns) is an error and is left as it is: appending rows of another layout would corrupt it.
pub fn truncate_csv_after_step(path: &Path, header: &str, step: usize) -> anyhow::Result<()> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let found = text.lines().next().unwrap_or("");
    if found != header {
        anyhow::bail!(
            "cannot resume into {}: its header has other columns than this version writes; \
             move the CSV away or resume with --out in a fresh directory holding a copy of the \
             checkpoint",
            path.display()
        );
    }
    let k = header.split(',').position(|c| c == "step").unwrap_or(0);
    let mut kept = String::with_capacity(text.len());
    for (i, line) in text.lines().enumerate() {
        let later = i > 0
            && line
                .split(',')
                .nth(k)
                .and_then(|s| s.parse::<f64>().ok())
                .is_some_and(|s| s > step as f64);
        if !later {
            kept.push_str(line);
            kept.push('\n');
        }
    }
    if kept.len() != text.len() {
        write_atomic(path, kept.as_bytes())
            .with_context(|| format!("replacing {}", path.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run interrupted after its last checkpoint has CSV rows past it; resuming drops them
    /// (they are recomputed) so the continued series has each step once.
    #[test]
    fn resumed_csv_drops_rows_after_the_checkpoint() {
        let dir = std::env::temp_dir().join(format!("dgsph-resume-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("c_dg.csv");
        std::fs::write(&path, "step,t\n0,0\n800,1\n900,1.1\n1100,1.4\n").unwrap();
        truncate_csv_after_step(&path, "step,t", 800).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, "step,t\n0,0\n800,1\n");
        // A CSV of another layout is refused and left untouched.
        let err = truncate_csv_after_step(&path, "step,t,extra", 0).unwrap_err();
        assert!(err.to_string().contains("other columns"), "{err}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), text);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn csv_values_round_trip_and_nan_is_empty() {
        for v in [0.1 + 0.2, 1e-300, -3.5, 12.0, f64::MAX] {
            assert_eq!(csv_value(v).parse::<f64>().unwrap().to_bits(), v.to_bits());
        }
        assert_eq!(csv_value(f64::NAN), "");
        assert_eq!(csv_value(12.0), "12");
    }
}
