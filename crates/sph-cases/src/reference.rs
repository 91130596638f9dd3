//! Reference data, embedded at compile time from `cases/reference/` (see its README for
//! sources and derivations). Nothing is read from disk at run time.

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

/// A tabulated exact drop solution.
#[derive(Clone, Debug)]
pub struct DropSolution {
    rows: Vec<DropState>,
}

const DROP_2D: &str = include_str!("../../../cases/reference/elliptical_drop_2d.csv");
const DROP_3D: &str = include_str!("../../../cases/reference/ellipsoid_3d.csv");

impl DropSolution {
    /// The exact 2D elliptical drop (Monaghan 1994 ansatz; paper Eq. 29 initial state).
    pub fn elliptical_2d() -> Self {
        Self::parse(DROP_2D)
    }

    /// The exact 3D spheroid (paper Eq. 30 initial state).
    pub fn spheroid_3d() -> Self {
        Self::parse(DROP_3D)
    }

    fn parse(text: &str) -> Self {
        let rows = text
            .lines()
            .skip(1)
            .filter(|l| !l.trim().is_empty())
            .map(|l| {
                let v: Vec<f64> = l
                    .split(',')
                    .map(|x| x.trim().parse().expect("embedded reference CSV"))
                    .collect();
                DropState {
                    t: v[0],
                    a: v[1],
                    b: v[2],
                    strain: v[3],
                    p_c: v[4],
                }
            })
            .collect();
        Self { rows }
    }

    /// Last tabulated time (t at which b = 1).
    pub fn t_max(&self) -> f64 {
        self.rows.last().map_or(0.0, |r| r.t)
    }

    /// Linear interpolation at `t` (clamped to the table). The table spacing (≈ 1.2e-5 in 2D)
    /// keeps the interpolation error below 1e-6 relative.
    pub fn at(&self, t: f64) -> DropState {
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

const SLOPES: &str = include_str!("../../../cases/reference/volume_slopes.csv");

/// The tabulated exact Section 3 slope `ln(det F)/Δt` for `case` (`2d_sec3`, `3d_sec3`,
/// `3d_sec5_initial`), `scheme` (`euler`, `pc`) and `dt`.
pub fn volume_slope(case: &str, scheme: &str, dt: f64) -> Option<f64> {
    SLOPES.lines().skip(1).find_map(|l| {
        let f: Vec<&str> = l.split(',').collect();
        let row_dt: f64 = f.get(3)?.parse().ok()?;
        (f[0] == case && f[2] == scheme && (row_dt - dt).abs() < 1e-12)
            .then(|| f[4].parse().ok())?
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_values_match_the_tables() {
        // drop_key_values.csv, quoted: 2D t = 0.003 a = 0.735723639507, p_c = 3489.18692277.
        let d2 = DropSolution::elliptical_2d();
        let s = d2.at(0.003);
        assert!(
            (s.a - 0.735723639507).abs() < 1e-6 && (s.p_c / 3489.18692277 - 1.0).abs() < 1e-5,
            "{s:?}"
        );
        assert!((d2.t_max() - 0.00349389062342).abs() < 1e-12);
        let d3 = DropSolution::spheroid_3d();
        let s = d3.at(0.003);
        assert!(
            (s.b - 0.826275698272).abs() < 1e-6 && (s.p_c / 2238.31895809 - 1.0).abs() < 1e-5,
            "{s:?}"
        );
        assert_eq!(
            volume_slope("2d_sec3", "euler", 1.25e-4),
            Some(-1.250097666)
        );
        assert_eq!(
            volume_slope("3d_sec3", "pc", 1.25e-4),
            Some(-0.001925773614)
        );
    }
}
