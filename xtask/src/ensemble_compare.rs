//! `cargo xtask ensemble-compare BASE.csv OTHER.csv`: whether two ensembles differ by more
//! than their round-off spread. Reads two `<tag>_ensemble.csv` files written by `cargo xtask
//! ensemble` and, for every scheme and result the two share, gives each side's completed
//! draws and mean, the difference `other − base` (absolute and relative to the base mean) and
//! the difference in standard errors, `z`:
//!
//! * both sides with `n ≥ 2` draws: `z = (x̄_o − x̄_b) / √(SE_b² + SE_o²)` (the difference of
//!   two means over its standard error);
//! * one side a single draw `x` (a run from before the ensembles, a table's one value) and the
//!   other `n ≥ 2` draws with mean `x̄` and SD `s`: `z = ±(x − x̄) / (s √(1 + 1/n))` — how far
//!   the single draw lies from the distribution's mean in units of a new draw's spread (its
//!   prediction SD), signed `other − base`;
//! * both single draws: no `z` (no spread is known); sides without spread (every draw equal)
//!   give no `z` when they agree and `±inf` when they differ.
//!
//! Draws marked `failed` are left out. Writes the Markdown table to `--out` (default
//! `target/ensemble/compare.md`) and prints it; exits 0, or 2 naming the file and line when a
//! file cannot be read or a row is malformed. It judges nothing: `|z|` below about 2 is a
//! difference the draws do not resolve.

use crate::ensemble::{CSV_HEADER, stats};
use crate::flags::CompareArgs;
use anyhow::{Context, anyhow};
use dgsph::session::{AppError, exit};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Completed draws of one file: (scheme, result) → values in file order.
pub type Ensemble = BTreeMap<(String, String), Vec<f64>>;

/// Reads an ensemble CSV (`scheme,draw,dt,status,result,value`), completed rows only.
pub fn read(path: &Path) -> Result<Ensemble, AppError> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading {}", path.display()))
        .map_err(AppError::Input)?;
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, header)) if header == CSV_HEADER => {}
        other => {
            return Err(AppError::Input(anyhow!(
                "{}:1: not an ensemble CSV: expected the header `{CSV_HEADER}`, found {:?}",
                path.display(),
                other.map(|(_, l)| l).unwrap_or_default()
            )));
        }
    }
    let mut out = Ensemble::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let bad =
            |why: &str| AppError::Input(anyhow!("{}:{}: {why}: {line:?}", path.display(), i + 1));
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 6 {
            return Err(bad("expected 6 comma-separated fields"));
        }
        let value: f64 = f[5]
            .trim()
            .parse()
            .map_err(|_| bad("the value is not a number"))?;
        match f[3] {
            "completed" => out
                .entry((f[0].to_string(), f[4].to_string()))
                .or_default()
                .push(value),
            "failed" => {}
            _ => return Err(bad("status must be `completed` or `failed`")),
        }
    }
    Ok(out)
}

/// One compared result.
#[derive(Debug, PartialEq)]
pub struct Row {
    pub n_base: usize,
    pub mean_base: f64,
    pub n_other: usize,
    pub mean_other: f64,
    /// `mean_other − mean_base`.
    pub diff: f64,
    /// The difference in standard errors (see the module doc); NaN when no spread is known.
    pub z: f64,
}

impl Row {
    /// The difference relative to the base mean, in per cent; "—" when the base mean is 0
    /// (a count that stayed 0, say) or not a number.
    pub fn relative_cell(&self) -> String {
        let rel = 100.0 * self.diff / self.mean_base.abs();
        if rel.is_finite() {
            format!("{rel:+.1} %")
        } else {
            "—".into()
        }
    }

    /// `z` to two decimals; "—" when no spread is known (NaN: single draws on both sides, or
    /// equal constant values); `±inf` when both sides are constant and differ.
    pub fn z_cell(&self) -> String {
        if self.z.is_nan() {
            "—".into()
        } else {
            format!("{:+.2}", self.z)
        }
    }
}

/// Compares the finite values of one result.
pub fn compare_values(base: &[f64], other: &[f64]) -> Row {
    let (b, o) = (stats(base), stats(other));
    let diff = o.mean - b.mean;
    let prediction = |s: &crate::ensemble::Stats| s.sd * (1.0 + 1.0 / s.n as f64).sqrt();
    let z = match (b.n, o.n) {
        (nb, no) if nb >= 2 && no >= 2 => diff / (b.se * b.se + o.se * o.se).sqrt(),
        (nb, 1) if nb >= 2 => diff / prediction(&b),
        (1, no) if no >= 2 => diff / prediction(&o),
        _ => f64::NAN,
    };
    Row {
        n_base: b.n,
        mean_base: b.mean,
        n_other: o.n,
        mean_other: o.mean,
        diff,
        z,
    }
}

/// Runs the comparison; returns the exit code.
pub fn run(args: &CompareArgs) -> Result<u8, AppError> {
    let base = read(&args.base)?;
    let other = read(&args.other)?;
    let mut md = format!(
        "# Ensemble comparison\n\nbase: `{}`; other: `{}`. Completed draws only. z: the \
         difference in standard errors — of the difference of the means when both sides have \
         two draws or more, of a new draw (SD √(1 + 1/n)) when one side is a single draw.\n\n\
         | scheme | result | n base | mean base | n other | mean other | other − base | \
         relative | z |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
        args.base.display(),
        args.other.display()
    );
    let mut shared = 0;
    for ((scheme, result), b) in &base {
        let Some(o) = other.get(&(scheme.clone(), result.clone())) else {
            continue;
        };
        shared += 1;
        let r = compare_values(b, o);
        let _ = writeln!(
            md,
            "| {scheme} | {result} | {} | {:.6e} | {} | {:.6e} | {:+.3e} | {} | {} |",
            r.n_base,
            r.mean_base,
            r.n_other,
            r.mean_other,
            r.diff,
            r.relative_cell(),
            r.z_cell()
        );
    }
    if shared == 0 {
        return Err(AppError::Input(anyhow!(
            "{} and {} share no (scheme, result) with completed draws",
            args.base.display(),
            args.other.display()
        )));
    }
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating {}", dir.display()))
            .map_err(AppError::Output)?;
    }
    dgsph::output::write_atomic(&args.out, md.as_bytes())
        .with_context(|| format!("writing {}", args.out.display()))
        .map_err(AppError::Output)?;
    dgsph::say_part!("{md}");
    dgsph::say!("wrote {}", args.out.display());
    Ok(exit::OK)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_ensembles_differ_by_the_difference_of_means_over_its_standard_error() {
        // base 1, 2, 3: mean 2, SD 1, SE 1/√3; other 2, 3, 4: mean 3, the same spread.
        // z = 1 / √(1/3 + 1/3) = √1.5.
        let r = compare_values(&[1.0, 2.0, 3.0], &[2.0, 3.0, 4.0]);
        assert_eq!((r.n_base, r.n_other), (3, 3));
        assert_eq!((r.mean_base, r.mean_other, r.diff), (2.0, 3.0, 1.0));
        assert!((r.z - 1.5f64.sqrt()).abs() < 1e-14, "{r:?}");
    }

    #[test]
    fn a_single_draw_against_a_distribution_uses_the_prediction_spread() {
        // base 1, 2, 3 (mean 2, SD 1, n 3); one draw at 4: z = 2 / √(1 + 1/3) = √3.
        let r = compare_values(&[1.0, 2.0, 3.0], &[4.0]);
        assert!((r.z - 3f64.sqrt()).abs() < 1e-14, "{r:?}");
        // Sides swapped: the sign follows other − base.
        let s = compare_values(&[4.0], &[1.0, 2.0, 3.0]);
        assert!((s.z + 3f64.sqrt()).abs() < 1e-14, "{s:?}");
        assert!(compare_values(&[1.0], &[2.0]).z.is_nan());
        // Non-finite values are not draws.
        let t = compare_values(&[1.0, f64::NAN, 2.0, 3.0], &[4.0]);
        assert_eq!(t, r);
    }

    #[test]
    fn cells_without_a_scale_or_a_spread_say_so() {
        // A count that stayed 0 on both sides: no relative difference, no spread.
        let zero = compare_values(&[0.0, 0.0], &[0.0, 0.0]);
        assert_eq!(
            (zero.relative_cell(), zero.z_cell()),
            ("—".into(), "—".into())
        );
        // Constant on both sides and different: a difference no spread explains.
        let apart = compare_values(&[5.0, 5.0], &[6.0, 6.0]);
        assert_eq!(
            (apart.relative_cell(), apart.z_cell()),
            ("+20.0 %".into(), "+inf".into())
        );
        let r = compare_values(&[1.0, 2.0, 3.0], &[2.0, 3.0, 4.0]);
        assert_eq!(
            (r.relative_cell(), r.z_cell()),
            ("+50.0 %".into(), "+1.22".into())
        );
    }
}
