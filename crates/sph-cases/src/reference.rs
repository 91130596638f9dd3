//! Reference data, embedded at compile time from `cases/reference/` (see its README for
//! sources and derivations). Nothing is read from disk at run time; a caller may build a
//! [`References`] set from other texts.

use crate::CaseError;

/// Exact drop solution at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DropState {
    /// Time.
    pub t: f64,
    /// Semi-axis along x.
    pub a: f64,
    /// Semi-axis along y (and z in 3D).
    pub b: f64,
    /// Strain rate A (u = −A x).
    pub strain: f64,
    /// Central pressure p_c.
    pub p_c: f64,
}

/// The exact drop solution: tabulated up to `t(b = 1)`, integrated beyond.
#[derive(Clone, Debug)]
pub struct DropSolution {
    rows: Vec<DropState>,
    dim: usize,
}

/// Right-hand side of the drop's ODE (ρ = 1), `cases/reference/README.md`:
/// 2D `a' = −A a`, `b' = A b`, `A' = A² (a² − b²)/(a² + b²)`;
/// 3D `a' = −A a`, `b' = A b/2`, `A' = A² (4a² − b²)/(2 (2a² + b²))`.
fn drop_rate(dim: usize, [a, b, s]: [f64; 3]) -> [f64; 3] {
    if dim == 2 {
        [-s * a, s * b, s * s * (a * a - b * b) / (a * a + b * b)]
    } else {
        [
            -s * a,
            0.5 * s * b,
            s * s * (4.0 * a * a - b * b) / (2.0 * (2.0 * a * a + b * b)),
        ]
    }
}

/// Central pressure (ρ = 1): 2D `A² a² b²/(a² + b²)`, 3D `(3/4) A² a² b²/(2a² + b²)`.
fn drop_pressure(dim: usize, a: f64, b: f64, s: f64) -> f64 {
    if dim == 2 {
        s * s * a * a * b * b / (a * a + b * b)
    } else {
        0.75 * s * s * a * a * b * b / (2.0 * a * a + b * b)
    }
}

/// Integrates the drop's ODE from `from` to time `t ≥ from.t` (classical Runge–Kutta, steps of
/// at most 1e-6: `A Δt ≤ 1.3e-4`, so the truncation error stays near round-off).
pub fn integrate_drop(dim: usize, from: DropState, t: f64) -> DropState {
    let span = (t - from.t).max(0.0);
    let n = (span / 1e-6).ceil().max(1.0) as usize;
    let h = span / n as f64;
    let mut y = [from.a, from.b, from.strain];
    let add =
        |y: [f64; 3], k: [f64; 3], w: f64| [y[0] + w * k[0], y[1] + w * k[1], y[2] + w * k[2]];
    for _ in 0..n {
        let k1 = drop_rate(dim, y);
        let k2 = drop_rate(dim, add(y, k1, 0.5 * h));
        let k3 = drop_rate(dim, add(y, k2, 0.5 * h));
        let k4 = drop_rate(dim, add(y, k3, h));
        for (i, yi) in y.iter_mut().enumerate() {
            *yi += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
    DropState {
        t,
        a: y[0],
        b: y[1],
        strain: y[2],
        p_c: drop_pressure(dim, y[0], y[1], y[2]),
    }
}

impl DropSolution {
    /// Parses a drop table (`t,a,b,strain,p_c` with a header line) of a `dim`-dimensional drop;
    /// `file` names it in errors.
    pub fn parse(file: &str, text: &str, dim: usize) -> Result<Self, CaseError> {
        let rows: Vec<DropState> = numeric_rows(file, text, 5)?
            .into_iter()
            .map(|v| DropState {
                t: v[0],
                a: v[1],
                b: v[2],
                strain: v[3],
                p_c: v[4],
            })
            .collect();
        if rows.len() < 2 || rows.windows(2).any(|w| w[1].t <= w[0].t) {
            return Err(CaseError::Reference {
                file: file.to_string(),
                line: 0,
                message: "needs at least two rows with increasing t".into(),
            });
        }
        Ok(Self { rows, dim })
    }

    /// Last tabulated time (t at which b = 1).
    pub fn t_max(&self) -> f64 {
        self.rows.last().map_or(0.0, |r| r.t)
    }

    /// The exact state at `t`: linear interpolation in the table up to its last time (the
    /// spacing, ≈ 1.2e-5 in 2D, keeps the interpolation error below 1e-6 relative), the ODE
    /// integrated from the table's last row beyond it ([`integrate_drop`]).
    pub fn at(&self, t: f64) -> DropState {
        let last = self.rows[self.rows.len() - 1];
        if t > last.t {
            return integrate_drop(self.dim, last, t);
        }
        let k = self
            .rows
            .partition_point(|r| r.t <= t)
            .clamp(1, self.rows.len() - 1);
        let (r0, r1) = (self.rows[k - 1], self.rows[k]);
        let w = ((t - r0.t) / (r1.t - r0.t)).clamp(0.0, 1.0);
        let lerp = |a: f64, b: f64| a + w * (b - a);
        DropState {
            t,
            a: lerp(r0.a, r1.a),
            b: lerp(r0.b, r1.b),
            strain: lerp(r0.strain, r1.strain),
            p_c: lerp(r0.p_c, r1.p_c),
        }
    }
}

/// Rows of numbers after a header line; every row must have at least `columns` numeric fields.
fn numeric_rows(file: &str, text: &str, columns: usize) -> Result<Vec<Vec<f64>>, CaseError> {
    text.lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(k, l)| {
            let v = l
                .split(',')
                .take(columns)
                .map(|x| x.trim().parse::<f64>())
                .collect::<Result<Vec<f64>, _>>()
                .map_err(|e| CaseError::Reference {
                    file: file.to_string(),
                    line: k + 1,
                    message: format!("{e} in {l:?}"),
                })?;
            if v.len() < columns {
                return Err(CaseError::Reference {
                    file: file.to_string(),
                    line: k + 1,
                    message: format!("expected {columns} numeric columns, found {}", v.len()),
                });
            }
            Ok(v)
        })
        .collect()
}

/// One row of `volume_slopes.csv`.
#[derive(Clone, Debug, PartialEq)]
struct SlopeRow {
    case: String,
    scheme: String,
    dt: f64,
    slope: f64,
}

/// A Ghia et al. (1982) centreline table: coordinates and one column per Reynolds number.
#[derive(Clone, Debug, PartialEq)]
struct GhiaTable {
    reynolds: Vec<f64>,
    rows: Vec<(f64, Vec<f64>)>,
}

impl GhiaTable {
    fn parse(file: &str, text: &str) -> Result<Self, CaseError> {
        let header = text.lines().next().unwrap_or_default();
        let reynolds = header
            .split(',')
            .skip(1)
            .map(|h| {
                h.trim()
                    .strip_prefix("Re")
                    .and_then(|v| v.parse::<f64>().ok())
                    .ok_or_else(|| CaseError::Reference {
                        file: file.to_string(),
                        line: 1,
                        message: format!("column {h:?} is not of the form Re<number>"),
                    })
            })
            .collect::<Result<Vec<f64>, _>>()?;
        let rows = numeric_rows(file, text, reynolds.len() + 1)?
            .into_iter()
            .map(|v| (v[0], v[1..].to_vec()))
            .collect();
        Ok(Self { reynolds, rows })
    }

    /// `(coordinate, value at re)`; values are NaN when `re` is not tabulated.
    fn at(&self, re: f64) -> Vec<(f64, f64)> {
        let col = self.reynolds.iter().position(|r| *r == re);
        self.rows
            .iter()
            .map(|(c, v)| (*c, col.map_or(f64::NAN, |k| v[k])))
            .collect()
    }
}

/// Every reference table a validation run compares against. [`References::embedded`] is the
/// copy in `cases/reference/` compiled into the library; [`References::parse`] builds a set
/// from other texts (the xtask's `--references DIR`, or a test that perturbs a value to check
/// that the perturbation makes a run fail).
#[derive(Clone, Debug)]
pub struct References {
    drop_2d: DropSolution,
    drop_3d: DropSolution,
    slopes: Vec<SlopeRow>,
    ghia_u: GhiaTable,
    ghia_v: GhiaTable,
    dam_break: Vec<(f64, f64)>,
}

const EMBEDDED: [(&str, &str); 6] = [
    (
        "elliptical_drop_2d.csv",
        include_str!("../../../cases/reference/elliptical_drop_2d.csv"),
    ),
    (
        "ellipsoid_3d.csv",
        include_str!("../../../cases/reference/ellipsoid_3d.csv"),
    ),
    (
        "volume_slopes.csv",
        include_str!("../../../cases/reference/volume_slopes.csv"),
    ),
    (
        "ghia_u_vertical.csv",
        include_str!("../../../cases/reference/ghia_u_vertical.csv"),
    ),
    (
        "ghia_v_horizontal.csv",
        include_str!("../../../cases/reference/ghia_v_horizontal.csv"),
    ),
    (
        "dam_break_martin_moyce.csv",
        include_str!("../../../cases/reference/dam_break_martin_moyce.csv"),
    ),
];

impl References {
    /// The file names of the reference set (in `cases/reference/`).
    pub const FILES: [&'static str; 6] = [
        EMBEDDED[0].0,
        EMBEDDED[1].0,
        EMBEDDED[2].0,
        EMBEDDED[3].0,
        EMBEDDED[4].0,
        EMBEDDED[5].0,
    ];

    /// The reference set compiled into the library from `cases/reference/`.
    pub fn embedded() -> &'static References {
        static SET: std::sync::LazyLock<References> = std::sync::LazyLock::new(|| {
            References::parse(|_| None).expect("embedded reference tables parse (tested)")
        });
        &SET
    }

    /// Builds a reference set from the texts `text(file)` returns for the names in
    /// [`References::FILES`]; a file for which it returns `None` keeps its embedded copy.
    pub fn parse(mut text: impl FnMut(&str) -> Option<String>) -> Result<Self, CaseError> {
        let mut get = |k: usize| {
            let (file, embedded) = EMBEDDED[k];
            (file, text(file).unwrap_or_else(|| embedded.to_string()))
        };
        let (f, t) = get(0);
        let drop_2d = DropSolution::parse(f, &t, 2)?;
        let (f, t) = get(1);
        let drop_3d = DropSolution::parse(f, &t, 3)?;
        let (f, t) = get(2);
        let slopes = t
            .lines()
            .enumerate()
            .skip(1)
            .filter(|(_, l)| !l.trim().is_empty())
            .map(|(k, l)| {
                let c: Vec<&str> = l.split(',').collect();
                let num = |i: usize| {
                    c.get(i)
                        .and_then(|v| v.trim().parse::<f64>().ok())
                        .ok_or_else(|| CaseError::Reference {
                            file: f.to_string(),
                            line: k + 1,
                            message: format!("column {} is not a number in {l:?}", i + 1),
                        })
                };
                Ok(SlopeRow {
                    case: c[0].trim().to_string(),
                    scheme: c.get(2).map_or("", |s| s.trim()).to_string(),
                    dt: num(3)?,
                    slope: num(4)?,
                })
            })
            .collect::<Result<Vec<_>, CaseError>>()?;
        let (f, t) = get(3);
        let ghia_u = GhiaTable::parse(f, &t)?;
        let (f, t) = get(4);
        let ghia_v = GhiaTable::parse(f, &t)?;
        let (f, t) = get(5);
        let dam_break: Vec<(f64, f64)> = numeric_rows(f, &t, 2)?
            .into_iter()
            .map(|v| (v[0], v[1]))
            .collect();
        if dam_break.len() < 2 || dam_break.windows(2).any(|w| w[1].0 <= w[0].0) {
            return Err(CaseError::Reference {
                file: f.to_string(),
                line: 0,
                message: "needs at least two rows with increasing T".into(),
            });
        }
        Ok(Self {
            drop_2d,
            drop_3d,
            slopes,
            ghia_u,
            ghia_v,
            dam_break,
        })
    }

    /// The exact drop solution in `dim` dimensions: the 2D elliptical drop (Monaghan 1994
    /// ansatz; paper Eq. 29 initial state) or the 3D spheroid (paper Eq. 30).
    pub fn drop(&self, dim: usize) -> &DropSolution {
        if dim == 2 {
            &self.drop_2d
        } else {
            &self.drop_3d
        }
    }

    /// The tabulated exact Section 3 slope `ln(det F)/Δt` for `case` (`2d_sec3`, `3d_sec3`,
    /// `3d_sec5_initial`), `scheme` (`euler`, `pc`) and `dt`.
    pub fn volume_slope(&self, case: &str, scheme: &str, dt: f64) -> Option<f64> {
        self.slopes
            .iter()
            .find(|r| r.case == case && r.scheme == scheme && (r.dt - dt).abs() < 1e-12)
            .map(|r| r.slope)
    }

    /// Ghia et al.'s `u(0.5, y)` at `re` as `(y, u)` rows (NaN values if `re` is not tabulated).
    pub fn ghia_u_vertical(&self, re: f64) -> Vec<(f64, f64)> {
        self.ghia_u.at(re)
    }

    /// Ghia et al.'s `v(x, 0.5)` at `re` as `(x, v)` rows (NaN values if `re` is not tabulated).
    pub fn ghia_v_horizontal(&self, re: f64) -> Vec<(f64, f64)> {
        self.ghia_v.at(re)
    }

    /// Martin & Moyce's (1952) surge front `(T, Z)`, `T = t√(2g/a)`, `Z = z/a` (n² = 2).
    pub fn dam_break_front(&self) -> &[(f64, f64)] {
        &self.dam_break
    }

    /// Martin & Moyce's front `Z` at `T`, linearly interpolated; `None` outside the data.
    pub fn dam_break_front_at(&self, t: f64) -> Option<f64> {
        let d = &self.dam_break;
        let k = d.partition_point(|r| r.0 <= t);
        if k == 0 || k == d.len() && d[k - 1].0 < t {
            return None;
        }
        if k == d.len() {
            return Some(d[k - 1].1);
        }
        let (a, b) = (d[k - 1], d[k]);
        Some(a.1 + (b.1 - a.1) * (t - a.0) / (b.0 - a.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_values_match_the_tables() {
        // drop_key_values.csv, quoted: 2D t = 0.003 a = 0.735723639507, p_c = 3489.18692277.
        let refs = References::embedded();
        let d2 = refs.drop(2);
        let s = d2.at(0.003);
        assert!(
            (s.a - 0.735723639507).abs() < 1e-6 && (s.p_c / 3489.18692277 - 1.0).abs() < 1e-5,
            "{s:?}"
        );
        assert!((d2.t_max() - 0.00349389062342).abs() < 1e-12);
        let d3 = refs.drop(3);
        let s = d3.at(0.003);
        assert!(
            (s.b - 0.826275698272).abs() < 1e-6 && (s.p_c / 2238.31895809 - 1.0).abs() < 1e-5,
            "{s:?}"
        );
        assert_eq!(
            refs.volume_slope("2d_sec3", "euler", 1.25e-4),
            Some(-1.250097666)
        );
        assert_eq!(
            refs.volume_slope("3d_sec3", "pc", 1.25e-4),
            Some(-0.001925773614)
        );
    }

    /// The ODE used beyond the tables, integrated from the initial state over the tables'
    /// whole range, reproduces every tabulated row (both drops), and keeps the energy invariant
    /// `A² (a² + b²)` (2D) / `A² (a² + b²/2)` (3D) far beyond them. A wrong sign or factor in
    /// any rate term moves the rows by far more than the tolerance.
    #[test]
    fn drop_ode_reproduces_the_tables_and_keeps_its_invariant() {
        for dim in [2, 3] {
            let sol = References::embedded().drop(dim);
            let start = sol.rows[0];
            let mut worst = 0.0_f64;
            let mut state = start;
            for row in &sol.rows[1..] {
                state = integrate_drop(dim, state, row.t);
                for (x, r) in [
                    (state.a, row.a),
                    (state.b, row.b),
                    (state.strain, row.strain),
                    (state.p_c, row.p_c),
                ] {
                    worst = worst.max((x / r - 1.0).abs());
                }
            }
            assert!(
                worst < 1e-9,
                "{dim}D: largest relative difference {worst:e}"
            );
            let invariant = |s: DropState| {
                let w = if dim == 2 { 1.0 } else { 0.5 };
                s.strain * s.strain * (s.a * s.a + w * s.b * s.b)
            };
            let far = sol.at(5.0 * sol.t_max());
            assert!(far.t > sol.t_max() && far.b > 1.0 && far.a < start.a);
            let drift = invariant(far) / invariant(start) - 1.0;
            assert!(drift.abs() < 1e-10, "{dim}D: invariant drift {drift:e}");
            // Incompressibility: a b (2D), a b² (3D) constant.
            let area = |s: DropState| s.a * s.b.powi(dim as i32 - 1);
            assert!((area(far) / area(start) - 1.0).abs() < 1e-10);
        }
    }

    #[test]
    fn a_perturbed_ghia_value_moves_the_deviation_by_exactly_the_perturbation() {
        use crate::cavity::{Profiles, ghia_deviation};
        let embedded = References::embedded();
        let original = EMBEDDED[3].1;
        let row = "0.5000,-0.20581,"; // u(0.5, 0.5) at Re 100, then Re 400 onwards
        assert!(original.contains(row), "reference row moved");
        let text = original.replace(row, "0.5000,-0.21581,");
        let perturbed =
            References::parse(|f| (f == "ghia_u_vertical.csv").then(|| text.clone())).unwrap();
        let profiles = |r: &References| Profiles {
            u_vertical: r
                .ghia_u_vertical(100.0)
                .into_iter()
                .map(|(y, g)| (y, g, g))
                .collect(),
            v_horizontal: r
                .ghia_v_horizontal(100.0)
                .into_iter()
                .map(|(x, g)| (x, g, g))
                .collect(),
        };
        // Our profile equals the embedded table; deviation against the perturbed table.
        let mut ours = profiles(embedded);
        let theirs = profiles(&perturbed);
        for (mine, reference) in ours.u_vertical.iter_mut().zip(&theirs.u_vertical) {
            mine.2 = reference.2;
        }
        let d = ghia_deviation(&ours, 100.0).unwrap();
        assert!((d.u_max - 0.01).abs() < 1e-12, "{d:?}");
        assert_eq!(d.v_max, 0.0);
        assert_eq!(
            ghia_deviation(&profiles(embedded), 100.0).unwrap().u_max,
            0.0
        );
    }

    #[test]
    fn the_re_3200_misprint_is_left_out_of_the_deviation() {
        // Ghia's Re 3200 u(0.4531) = −0.86636 (between −0.24427 and −0.04272) is a misprint: a
        // profile through the neighbouring values deviates from the table only there, and the
        // deviation must not see it.
        use crate::cavity::{Profiles, ghia_deviation};
        let r = References::embedded();
        let u = r.ghia_u_vertical(3200.0);
        let at = |y: f64| u.iter().find(|(c, _)| (c - y).abs() < 1e-6).unwrap().1;
        assert_eq!(at(0.4531), -0.86636, "the table's printed value");
        let smooth = 0.5 * (at(0.2813) + at(0.5));
        let profiles = Profiles {
            u_vertical: u
                .iter()
                .map(|&(y, g)| (y, if (y - 0.4531).abs() < 1e-6 { smooth } else { g }, g))
                .collect(),
            v_horizontal: r
                .ghia_v_horizontal(3200.0)
                .into_iter()
                .map(|(x, g)| (x, g, g))
                .collect(),
        };
        let d = ghia_deviation(&profiles, 3200.0).unwrap();
        assert_eq!((d.u_rms, d.u_max), (0.0, 0.0), "{d:?}");
        // At another Reynolds number the same row counts.
        let d = ghia_deviation(&profiles, 5000.0).unwrap();
        assert!(d.u_max > 0.7, "{d:?}");
    }

    #[test]
    fn malformed_tables_name_file_and_line() {
        let bad = EMBEDDED[4].1.replacen("Re100", "R100", 1);
        let e = References::parse(|f| (f == "ghia_v_horizontal.csv").then(|| bad.clone()))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("ghia_v_horizontal.csv, line 1") && e.contains("R100"),
            "{e}"
        );
        let short = "t,a,b,A,p_c\n0,1,0.7,100\n";
        let e = References::parse(|f| (f == "ellipsoid_3d.csv").then(|| short.to_string()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("ellipsoid_3d.csv, line 2"), "{e}");
    }
}
