//! Seeded random numbers and lattice generators for tests and benches.
//!
//! A tiny SplitMix64 generator is used instead of a dependency: tests only need reproducible,
//! well-mixed uniform numbers, and SplitMix64 (Steele, Lea & Flood 2014) is 10 lines.

use crate::{Dim, VectorOps};

/// SplitMix64: a fast, seedable 64-bit generator (not cryptographic).
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator with the given seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let unit = (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        lo + (hi - lo) * unit
    }

    /// A vector with components uniform in `[lo, hi)`.
    pub fn vector<D: Dim>(&mut self, lo: f64, hi: f64) -> D::Vector {
        D::Vector::from_fn(|_| self.uniform(lo, hi))
    }
}

/// A regular lattice of `per_side^DIM` points with spacing `dx`, centred on the origin.
///
/// Points are ordered with x fastest.
pub fn lattice<D: Dim>(per_side: usize, dx: f64) -> Vec<D::Vector> {
    let total = per_side.pow(D::DIM as u32);
    let offset = 0.5 * (per_side as f64 - 1.0) * dx;
    (0..total)
        .map(|mut k| {
            D::Vector::from_fn(|_| {
                let c = k % per_side;
                k /= per_side;
                c as f64 * dx - offset
            })
        })
        .collect()
}

/// `count` points uniform in the cube `[lo, hi)^DIM`.
pub fn random_cloud<D: Dim>(count: usize, lo: f64, hi: f64, seed: u64) -> Vec<D::Vector> {
    let mut rng = SplitMix64::new(seed);
    (0..count).map(|_| rng.vector::<D>(lo, hi)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    crate::dim_tests! {
        fn lattice_is_centred_with_spacing<D>() {
            let pts = lattice::<D>(5, 0.1);
            assert_eq!(pts.len(), 5usize.pow(D::DIM as u32));
            let sum: D::Vector = pts.iter().copied().sum();
            assert!(sum.length() < 1e-12);
            assert!(((pts[1] - pts[0]).length() - 0.1).abs() < 1e-15);
        }
    }

    #[test]
    fn rng_is_reproducible_and_in_range() {
        let mut a = SplitMix64::new(3);
        let mut b = SplitMix64::new(3);
        for _ in 0..1000 {
            let x = a.uniform(-2.0, 5.0);
            assert_eq!(x, b.uniform(-2.0, 5.0));
            assert!((-2.0..5.0).contains(&x));
        }
    }
}
