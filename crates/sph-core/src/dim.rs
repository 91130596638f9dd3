//! The dimension abstraction.
//!
//! glam has no trait common to `DVec2` and `DVec3`, so [`VectorOps`] and [`MatrixOps`] provide the
//! handful of operations the physics needs. Everything that truly differs between 2D and 3D lives
//! in exactly one `impl` for [`D2`] and one for [`D3`]; generic code may branch on `D::DIM` only to
//! pick constants (the branch is folded at compile time).

use glam::{DMat2, DMat3, DVec2, DVec3};
use std::fmt;
use std::ops::{Add, AddAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A spatial dimension: `D2` or `D3`.
pub trait Dim: Copy + Send + Sync + fmt::Debug + Default + 'static {
    /// Number of spatial dimensions, 2 or 3.
    const DIM: usize;
    /// Number of independent components of a symmetric `DIM × DIM` tensor (3 or 6).
    const SYM: usize;
    /// Position / velocity vector type (`DVec2` or `DVec3`).
    type Vector: VectorOps;
    /// Square matrix type (`DMat2` or `DMat3`), column-major as in glam.
    type Matrix: MatrixOps<Self::Vector>;
    /// Short name used in reports and bench ids: `"2d"` or `"3d"`.
    const NAME: &'static str;
}

/// Two spatial dimensions (glam `DVec2` / `DMat2`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct D2;

/// Three spatial dimensions (glam `DVec3` / `DMat3`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct D3;

impl Dim for D2 {
    const DIM: usize = 2;
    const SYM: usize = 3;
    type Vector = DVec2;
    type Matrix = DMat2;
    const NAME: &'static str = "2d";
}

impl Dim for D3 {
    const DIM: usize = 3;
    const SYM: usize = 6;
    type Vector = DVec3;
    type Matrix = DMat3;
    const NAME: &'static str = "3d";
}

/// Vector operations shared by `DVec2` and `DVec3`.
pub trait VectorOps:
    Copy
    + Send
    + Sync
    + fmt::Debug
    + PartialEq
    + Default
    + Add<Output = Self>
    + Sub<Output = Self>
    + Neg<Output = Self>
    + Mul<f64, Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign<f64>
    + std::iter::Sum
    + 'static
{
    /// Number of components.
    const DIM: usize;
    /// The zero vector.
    const ZERO: Self;
    /// Component `i` (0 = x, 1 = y, 2 = z). Panics if `i >= DIM`.
    fn get(&self, i: usize) -> f64;
    /// Sets component `i`. Panics if `i >= DIM`.
    fn set(&mut self, i: usize, value: f64);
    /// Builds a vector from a function of the component index.
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    /// Dot product.
    fn dot(self, other: Self) -> f64;
    /// Squared Euclidean length.
    fn length_squared(self) -> f64;
    /// Euclidean length.
    fn length(self) -> f64 {
        self.length_squared().sqrt()
    }
    /// Component-wise minimum.
    fn min(self, other: Self) -> Self;
    /// Component-wise maximum.
    fn max(self, other: Self) -> Self;
    /// True if every component is finite.
    fn is_finite(self) -> bool;
    /// The components as a `[f64; 3]`, the unused trailing entries zero.
    fn to_array3(self) -> [f64; 3] {
        let mut a = [0.0; 3];
        for (i, ai) in a.iter_mut().enumerate().take(Self::DIM) {
            *ai = self.get(i);
        }
        a
    }
}

/// Square-matrix operations shared by `DMat2` and `DMat3`.
///
/// Entries are addressed as `(row, col)`; glam stores matrices column-major, so
/// `m.get(i, j) == m.col(j)[i]`.
pub trait MatrixOps<V: VectorOps>:
    Copy
    + Send
    + Sync
    + fmt::Debug
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<f64, Output = Self>
    + Mul<V, Output = V>
    + Mul<Self, Output = Self>
    + AddAssign
    + SubAssign
    + 'static
{
    /// The zero matrix.
    const ZERO: Self;
    /// The identity matrix.
    const IDENTITY: Self;
    /// Entry in row `i`, column `j`.
    fn get(&self, i: usize, j: usize) -> f64;
    /// Sets the entry in row `i`, column `j`.
    fn set(&mut self, i: usize, j: usize, value: f64);
    /// Builds a matrix from a function of `(row, col)`.
    fn from_fn(f: impl FnMut(usize, usize) -> f64) -> Self;
    /// Outer product `a ⊗ b`, the matrix with entries `a_i b_j`.
    fn outer(a: V, b: V) -> Self;
    /// Determinant.
    fn determinant(&self) -> f64;
    /// Transpose.
    fn transpose(&self) -> Self;
    /// Inverse, or `None` when the matrix is singular (|det| ≤ `min_det`) or not finite.
    fn try_inverse(&self, min_det: f64) -> Option<Self>;
    /// Trace `Σ_i m_ii`.
    fn trace(&self) -> f64;
    /// Cofactor matrix `cof(M)_ij = (−1)^{i+j} det(minor_ij)`, so that `M cof(M)ᵀ = det(M) I`
    /// and `∂ det M / ∂ M_ij = cof(M)_ij`.
    fn cofactor(&self) -> Self;
    /// Double contraction `A : B = Σ_ij A_ij B_ij`.
    fn contract(&self, other: &Self) -> f64;
    /// Quadratic form `xᵀ M x`, evaluated as `Σ_k M_kk x_k² + Σ_{k<l} (M_kl + M_lk) x_k x_l`
    /// (5 multiplications in 2D, 9 in 3D, against 6 and 12 for `x·(M x)`; the pair sums are
    /// loop-invariant where `M` is).
    fn quadratic_form(&self, x: V) -> f64;
    /// True if every entry is finite.
    fn is_finite(&self) -> bool;
}

macro_rules! impl_vector_ops {
    ($v:ty, $n:expr) => {
        impl VectorOps for $v {
            const DIM: usize = $n;
            const ZERO: Self = <$v>::ZERO;
            #[inline(always)]
            fn get(&self, i: usize) -> f64 {
                self[i]
            }
            #[inline(always)]
            fn set(&mut self, i: usize, value: f64) {
                self[i] = value;
            }
            #[inline(always)]
            fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
                let mut v = <$v>::ZERO;
                for i in 0..$n {
                    v[i] = f(i);
                }
                v
            }
            #[inline(always)]
            fn dot(self, other: Self) -> f64 {
                <$v>::dot(self, other)
            }
            #[inline(always)]
            fn length_squared(self) -> f64 {
                <$v>::length_squared(self)
            }
            #[inline(always)]
            fn min(self, other: Self) -> Self {
                <$v>::min(self, other)
            }
            #[inline(always)]
            fn max(self, other: Self) -> Self {
                <$v>::max(self, other)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$v>::is_finite(self)
            }
        }
    };
}
impl_vector_ops!(DVec2, 2);
impl_vector_ops!(DVec3, 3);

macro_rules! impl_matrix_common {
    ($m:ty, $v:ty, $n:expr) => {
        const ZERO: Self = <$m>::ZERO;
        const IDENTITY: Self = <$m>::IDENTITY;
        #[inline(always)]
        fn get(&self, i: usize, j: usize) -> f64 {
            self.col(j)[i]
        }
        #[inline(always)]
        fn set(&mut self, i: usize, j: usize, value: f64) {
            self.col_mut(j)[i] = value;
        }
        #[inline(always)]
        fn from_fn(mut f: impl FnMut(usize, usize) -> f64) -> Self {
            let mut m = <$m>::ZERO;
            for j in 0..$n {
                for i in 0..$n {
                    m.col_mut(j)[i] = f(i, j);
                }
            }
            m
        }
        #[inline(always)]
        fn outer(a: $v, b: $v) -> Self {
            // Column j of a ⊗ b is a * b_j.
            let mut m = <$m>::ZERO;
            for j in 0..$n {
                *m.col_mut(j) = a * b[j];
            }
            m
        }
        #[inline(always)]
        fn determinant(&self) -> f64 {
            <$m>::determinant(self)
        }
        #[inline(always)]
        fn transpose(&self) -> Self {
            <$m>::transpose(self)
        }
        #[inline]
        fn try_inverse(&self, min_det: f64) -> Option<Self> {
            let det = <$m>::determinant(self);
            if !det.is_finite() || det.abs() <= min_det {
                return None;
            }
            Some(self.cofactor().transpose() * (1.0 / det))
        }
        #[inline(always)]
        fn trace(&self) -> f64 {
            (0..$n).map(|i| self.col(i)[i]).sum()
        }
        #[inline(always)]
        fn contract(&self, other: &Self) -> f64 {
            (0..$n).map(|j| self.col(j).dot(other.col(j))).sum()
        }
        #[inline(always)]
        fn is_finite(&self) -> bool {
            <$m>::is_finite(self)
        }
    };
}

impl MatrixOps<DVec2> for DMat2 {
    impl_matrix_common!(DMat2, DVec2, 2);
    #[inline(always)]
    fn cofactor(&self) -> Self {
        let (a, b, c, d) = (self.x_axis.x, self.y_axis.x, self.x_axis.y, self.y_axis.y);
        // M = [[a, b], [c, d]]  =>  cof(M) = [[d, −c], [−b, a]].
        DMat2::from_cols(DVec2::new(d, -b), DVec2::new(-c, a))
    }
    #[inline(always)]
    fn quadratic_form(&self, x: DVec2) -> f64 {
        let b01 = self.x_axis.y + self.y_axis.x;
        x.x * (self.x_axis.x * x.x + b01 * x.y) + self.y_axis.y * (x.y * x.y)
    }
}

impl MatrixOps<DVec3> for DMat3 {
    impl_matrix_common!(DMat3, DVec3, 3);
    #[inline(always)]
    fn cofactor(&self) -> Self {
        // Row i of cof(M) is the cross product of the other two rows (cyclically ordered).
        let r0 = self.row(0);
        let r1 = self.row(1);
        let r2 = self.row(2);
        DMat3::from_cols(r1.cross(r2), r2.cross(r0), r0.cross(r1)).transpose()
    }
    #[inline(always)]
    fn quadratic_form(&self, x: DVec3) -> f64 {
        let (c0, c1, c2) = (self.x_axis, self.y_axis, self.z_axis);
        let (b01, b02, b12) = (c0.y + c1.x, c0.z + c2.x, c1.z + c2.y);
        x.x * (c0.x * x.x + b01 * x.y + b02 * x.z)
            + x.y * (c1.y * x.y + b12 * x.z)
            + c2.z * (x.z * x.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::SplitMix64;

    fn random_matrix<D: Dim>(rng: &mut SplitMix64) -> D::Matrix {
        D::Matrix::from_fn(|_, _| rng.uniform(-1.0, 1.0))
    }

    crate::dim_tests! {
        fn cofactor_is_derivative_of_determinant<D>() {
            // ∂det(M)/∂M_ij = cof(M)_ij, checked by central differences.
            let mut rng = SplitMix64::new(7);
            for _ in 0..20 {
                let m = random_matrix::<D>(&mut rng);
                let cof = m.cofactor();
                for i in 0..D::DIM {
                    for j in 0..D::DIM {
                        let eps = 1e-6;
                        let mut p = m;
                        p.set(i, j, m.get(i, j) + eps);
                        let mut q = m;
                        q.set(i, j, m.get(i, j) - eps);
                        let fd = (p.determinant() - q.determinant()) / (2.0 * eps);
                        assert!((fd - cof.get(i, j)).abs() < 1e-8, "({i},{j}): {fd} vs {}", cof.get(i, j));
                    }
                }
                // M cof(M)^T = det(M) I.
                let prod = m * cof.transpose();
                let det = m.determinant();
                for i in 0..D::DIM {
                    for j in 0..D::DIM {
                        let expect = if i == j { det } else { 0.0 };
                        assert!((prod.get(i, j) - expect).abs() < 1e-12);
                    }
                }
            }
        }

        fn outer_product_and_entries<D>() {
            let a = D::Vector::from_fn(|i| 1.0 + i as f64);
            let b = D::Vector::from_fn(|i| 10.0 * (i as f64 + 1.0));
            let m = D::Matrix::outer(a, b);
            for i in 0..D::DIM {
                for j in 0..D::DIM {
                    assert_eq!(m.get(i, j), a.get(i) * b.get(j));
                }
            }
            // (a ⊗ b) v = a (b · v)
            let v = D::Vector::from_fn(|i| 0.5 - i as f64);
            let mv = m * v;
            let expect = a * b.dot(v);
            assert!((mv - expect).length() < 1e-12);
            assert_eq!(D::Matrix::IDENTITY.trace(), D::DIM as f64);
            assert_eq!(m.contract(&D::Matrix::IDENTITY), m.trace());
        }

        fn inverse_round_trips<D>() {
            let mut rng = SplitMix64::new(11);
            let m = random_matrix::<D>(&mut rng) + D::Matrix::IDENTITY * 3.0;
            let inv = m.try_inverse(1e-14).expect("well-conditioned");
            let p = m * inv;
            for i in 0..D::DIM {
                for j in 0..D::DIM {
                    let e = if i == j { 1.0 } else { 0.0 };
                    assert!((p.get(i, j) - e).abs() < 1e-12);
                }
            }
            assert!(D::Matrix::ZERO.try_inverse(1e-14).is_none());
        }

        /// `xᵀ M x` against the entry sum `Σ_ij x_i M_ij x_j`, for non-symmetric matrices
        /// (every off-diagonal pair must enter with both of its entries).
        fn quadratic_form_is_the_entry_sum<D>() {
            let mut rng = SplitMix64::new(12);
            for _ in 0..50 {
                let m = random_matrix::<D>(&mut rng);
                let x = rng.vector::<D>(-2.0, 2.0);
                let mut sum = 0.0;
                for i in 0..D::DIM {
                    for j in 0..D::DIM {
                        sum += x.get(i) * m.get(i, j) * x.get(j);
                    }
                }
                let q = m.quadratic_form(x);
                assert!((q - sum).abs() < 1e-13, "{q} against {sum}");
                assert!((q - x.dot(m * x)).abs() < 1e-13);
            }
        }
    }
}
