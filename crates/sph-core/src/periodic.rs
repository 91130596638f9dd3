//! Periodic axes of a box domain.
//!
//! A periodic axis `k` with period `L_k = hi_k − lo_k` identifies `x_k` with `x_k + L_k`. Pair
//! vectors are taken as the minimum image `d − L round(d / L)` along periodic axes, so every
//! operator sees a neighbour across the periodic boundary at its true distance; positions are
//! kept in `[lo_k, hi_k)` by [`Periodic::wrap`]. The neighbour search queries the images of a point
//! within the search radius of a periodic face.
//!
//! The period must exceed twice the search radius (checked by [`Periodic::check_radius`]): then a
//! particle has at most one image within the radius of another, and never sees its own image.

use crate::{Dim, VectorOps};

/// The periodic axes of a box `[lo, hi)`; axes that are not periodic have period 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Periodic<D: Dim> {
    lo: D::Vector,
    period: D::Vector,
}

/// Why a periodic description is invalid.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PeriodicError {
    /// No axis is periodic, or an axis index is out of range.
    #[error("periodic axes: {0}")]
    Axes(String),
    /// The box is empty or not finite along a periodic axis.
    #[error("periodic axis {axis}: the box [{lo}, {hi}) is empty or not finite")]
    Box {
        /// Axis (0 = x).
        axis: usize,
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
    /// The period is not larger than twice the search radius.
    #[error(
        "periodic axis {axis}: period {period} must exceed twice the kernel support {radius} \
         (a particle would see its own image)"
    )]
    TooShort {
        /// Axis.
        axis: usize,
        /// Its period.
        period: f64,
        /// The search radius.
        radius: f64,
    },
}

impl<D: Dim> Periodic<D> {
    /// The box `[lo, hi)` periodic along the axes `k` with `axes[k]` (entries beyond `D::DIM`
    /// must be false).
    pub fn new(lo: D::Vector, hi: D::Vector, axes: [bool; 3]) -> Result<Self, PeriodicError> {
        if axes.iter().skip(D::DIM).any(|a| *a) {
            return Err(PeriodicError::Axes(format!(
                "axis beyond the {}D domain",
                D::DIM
            )));
        }
        if !axes.iter().any(|a| *a) {
            return Err(PeriodicError::Axes("no axis is periodic".into()));
        }
        for k in 0..D::DIM {
            let (a, b) = (lo.get(k), hi.get(k));
            if axes[k] && !(a.is_finite() && b.is_finite() && a < b) {
                return Err(PeriodicError::Box {
                    axis: k,
                    lo: a,
                    hi: b,
                });
            }
        }
        Ok(Self {
            lo,
            period: D::Vector::from_fn(|k| if axes[k] { hi.get(k) - lo.get(k) } else { 0.0 }),
        })
    }

    /// Period along each axis (0 where the axis is not periodic).
    pub fn period(&self) -> D::Vector {
        self.period
    }

    /// Lower corner of the periodic box.
    pub fn lo(&self) -> D::Vector {
        self.lo
    }

    /// Whether axis `k` is periodic.
    pub fn is_periodic(&self, k: usize) -> bool {
        self.period.get(k) > 0.0
    }

    /// Refuses a search radius `r` with `2r ≥ L_k` on a periodic axis.
    pub fn check_radius(&self, r: f64) -> Result<(), PeriodicError> {
        for k in 0..D::DIM {
            let l = self.period.get(k);
            if l > 0.0 && 2.0 * r >= l {
                return Err(PeriodicError::TooShort {
                    axis: k,
                    period: l,
                    radius: r,
                });
            }
        }
        Ok(())
    }

    /// The minimum image of a pair vector `d = x_i − x_j`: `d_k − L_k round(d_k / L_k)` along
    /// periodic axes, `d_k` along the others.
    #[inline(always)]
    pub fn minimum_image(&self, d: D::Vector) -> D::Vector {
        D::Vector::from_fn(|k| {
            let (dk, l) = (d.get(k), self.period.get(k));
            if l > 0.0 {
                dk - l * (dk / l).round()
            } else {
                dk
            }
        })
    }

    /// `x` moved into `[lo_k, lo_k + L_k)` along every periodic axis.
    #[inline]
    pub fn wrap(&self, x: D::Vector) -> D::Vector {
        D::Vector::from_fn(|k| {
            let (xk, l) = (x.get(k), self.period.get(k));
            if l > 0.0 {
                let lo = self.lo.get(k);
                let w = lo + (xk - lo).rem_euclid(l);
                // rem_euclid can round up to exactly l for tiny negative offsets.
                if w >= lo + l { lo } else { w }
            } else {
                xk
            }
        })
    }

    /// Calls `f` with every image `q + Σ s_k L_k e_k` (`s_k ∈ {−1, 0, 1}`) of a query point `q`
    /// (inside the box) that can lie within `r` of a point of the box: the point itself first,
    /// then the shifts across the periodic faces `q` is closer than `r` to.
    #[inline]
    pub fn for_each_image(&self, q: D::Vector, r: f64, mut f: impl FnMut(D::Vector)) {
        // Shift per axis: 0 (none), or ±L when q is within r of the lower/upper face.
        let mut shifts = [0.0f64; 3];
        for (k, s) in shifts.iter_mut().enumerate().take(D::DIM) {
            let l = self.period.get(k);
            if l > 0.0 {
                let lo = self.lo.get(k);
                if q.get(k) - lo < r {
                    *s = l;
                } else if lo + l - q.get(k) < r {
                    *s = -l;
                }
            }
        }
        // Every combination of the non-zero shifts (at most 2^D images).
        for mask in 0u32..(1 << D::DIM) {
            if (0..D::DIM).any(|k| mask & (1 << k) != 0 && shifts[k] == 0.0) {
                continue;
            }
            f(D::Vector::from_fn(|k| {
                q.get(k) + if mask & (1 << k) != 0 { shifts[k] } else { 0.0 }
            }));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::SplitMix64;
    use crate::{D2, D3, dim_tests};

    fn unit<D: Dim>(axes: [bool; 3]) -> Periodic<D> {
        Periodic::new(
            D::Vector::ZERO,
            D::Vector::from_fn(|k| 1.0 + k as f64),
            axes,
        )
        .unwrap()
    }

    dim_tests! {
        fn minimum_image_is_the_shortest_periodic_copy<D>() {
            let p = unit::<D>([true, true, false]);
            let mut rng = SplitMix64::new(3);
            for _ in 0..200 {
                let a = p.wrap(rng.vector::<D>(-5.0, 5.0));
                let b = p.wrap(rng.vector::<D>(-5.0, 5.0));
                let d = p.minimum_image(a - b);
                // Brute force over the images of b.
                let mut best = f64::INFINITY;
                for s0 in -1..=1 {
                    for s1 in -1..=1 {
                        let shift = D::Vector::from_fn(|k| {
                            [s0 as f64, s1 as f64, 0.0][k] * p.period().get(k)
                        });
                        best = best.min((a - (b + shift)).length());
                    }
                }
                assert!((d.length() - best).abs() < 1e-12, "{d:?} vs {best}");
                if D::DIM == 3 {
                    // z is not periodic: the pair vector is untouched there.
                    assert_eq!(d.get(2), (a - b).get(2));
                }
            }
        }

        fn wrap_lands_in_the_box_and_images_cover_the_radius<D>() {
            let p = unit::<D>([true, false, D::DIM == 3]);
            let x = p.wrap(D::Vector::from_fn(|k| [-0.25, 7.0, 3.5][k]));
            assert!((x.get(0) - 0.75).abs() < 1e-15);
            assert_eq!(x.get(1), 7.0);
            if D::DIM == 3 {
                assert!((x.get(2) - 0.5).abs() < 1e-15);
            }
            // A point in a corner has 2^(periodic axes) images within r; one in the middle one.
            let mut n = 0;
            p.for_each_image(D::Vector::from_fn(|_| 0.05), 0.1, |_| n += 1);
            assert_eq!(n, if D::DIM == 2 { 2 } else { 4 });
            n = 0;
            p.for_each_image(D::Vector::from_fn(|_| 0.5), 0.1, |_| n += 1);
            assert_eq!(n, 1);
            assert!(p.check_radius(0.49).is_ok());
            assert!(matches!(p.check_radius(0.5), Err(PeriodicError::TooShort { axis: 0, .. })));
        }
    }

    #[test]
    fn invalid_descriptions_are_errors() {
        use glam::DVec2;
        assert!(Periodic::<D2>::new(DVec2::ZERO, DVec2::ONE, [false; 3]).is_err());
        assert!(Periodic::<D2>::new(DVec2::ZERO, DVec2::ONE, [false, false, true]).is_err());
        assert!(matches!(
            Periodic::<D2>::new(DVec2::ONE, DVec2::ZERO, [true, false, false]),
            Err(PeriodicError::Box { axis: 0, .. })
        ));
        assert!(
            Periodic::<D3>::new(glam::DVec3::ZERO, glam::DVec3::ONE, [false, false, true]).is_ok()
        );
    }
}
