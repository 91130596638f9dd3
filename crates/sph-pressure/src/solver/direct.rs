use crate::SolveError;
use crate::solver::{CsrSystem, LinearSolver, SolveInfo, SolveParams};
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};
use std::time::Instant;

/// faer's sparse LU with partial pivoting. Exact to round-off but `O(n^1.5)` memory and time in
/// 2D and worse in 3D: use it for small systems and as the oracle in tests.
#[derive(Clone, Copy, Debug, Default)]
pub struct SparseLu;

impl LinearSolver for SparseLu {
    fn name(&self) -> &'static str {
        "sparse-lu"
    }

    fn next_solve_is_fresh(&self) -> bool {
        true
    }

    fn solve(
        &mut self,
        a: &CsrSystem<'_>,
        x: &mut [f64],
        _params: &SolveParams,
    ) -> Result<SolveInfo, SolveError> {
        let t0 = Instant::now();
        // The factorisation needs the matrix itself: a border is written out.
        let mut written = super::Materialised::default();
        let a = if a.border.is_some() {
            written.fill(a);
            &written.system(a.rhs)
        } else {
            a
        };
        let n = a.n();
        let cols: Vec<usize> = a.cols.iter().map(|&c| c as usize).collect();
        let symbolic = SymbolicSparseRowMat::new_checked(n, n, a.offsets.to_vec(), None, cols);
        let mat = SparseRowMat::new(symbolic, a.values.to_vec());
        let lu = mat
            .sp_lu()
            .map_err(|e| SolveError::Direct(format!("{e:?}")))?;
        x.copy_from_slice(a.rhs);
        lu.solve_in_place(faer::MatMut::from_column_major_slice_mut(x, n, 1));
        let mut scratch = vec![0.0; n];
        let rel_residual = a.rel_residual(x, &mut scratch);
        if !rel_residual.is_finite() {
            return Err(SolveError::Direct(
                "non-finite solution (singular matrix?)".into(),
            ));
        }
        Ok(SolveInfo {
            iterations: 0,
            rel_residual,
            seconds: t0.elapsed().as_secs_f64(),
            setup_seconds: 0.0,
        })
    }
}
