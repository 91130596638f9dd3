use crate::SolveError;
use crate::csr::Operator;
use crate::solver::precond::PrecondState;
use crate::solver::{CsrSystem, Krylov, LinearSolver, Preconditioner, SolveInfo, SolveParams};
use rayon::prelude::*;
use std::time::Instant;

/// Right-preconditioned BiCGSTAB (van der Vorst 1992) on raw CSR slices, warm-started from the
/// caller's `x`. Convergence is judged on the recurrence residual and then confirmed on the true
/// residual `‖b − Ax‖` (the recurrence can drift far below it on ill-conditioned systems).
/// Buffers are kept between solves.
#[derive(Clone, Debug)]
pub struct BiCgStab {
    precond: Preconditioner,
    state: PrecondState,
    work: [Vec<f64>; 7],
    /// The warm start, kept for a retry with a fresh AMG hierarchy.
    x0: Vec<f64>,
}

impl BiCgStab {
    #[cfg(test)]
    pub(crate) fn amg_shape(&self) -> Vec<(usize, usize)> {
        self.state.amg_shape()
    }

    /// Whether AMG has ever written a bordered system out (rather than taking it in place).
    #[cfg(test)]
    pub(crate) fn amg_wrote_out(&self) -> bool {
        self.state.amg_wrote_out()
    }

    /// Whether the last solve used a kept AMG hierarchy.
    #[cfg(test)]
    pub(crate) fn reused_setup(&self) -> bool {
        self.state.reused()
    }

    /// A solver with the given preconditioner.
    pub fn new(precond: Preconditioner) -> Self {
        Self {
            precond,
            state: PrecondState::default(),
            work: Default::default(),
            x0: Vec::new(),
        }
    }
}

/// Restarts allowed after a (r̂₀, r) breakdown.
const MAX_RESTARTS: usize = 5;

/// `a · b` = [`tree_sum`] of the products `a_k b_k`, bitwise (the same tree, the same four
/// partial sums per leaf, written over slices so the leaf loop vectorises): the result does
/// not depend on the thread count, and nothing allocates.
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    const LEAF: usize = 4096;
    if a.len() <= LEAF {
        let mut s = [0.0; 4];
        let (aq, ar) = a.split_at(a.len() / 4 * 4);
        let (bq, br) = b[..a.len()].split_at(aq.len());
        for (x, y) in aq.chunks_exact(4).zip(bq.chunks_exact(4)) {
            for l in 0..4 {
                s[l] += x[l] * y[l];
            }
        }
        for (l, (x, y)) in ar.iter().zip(br).enumerate() {
            s[l] += x * y;
        }
        return (s[0] + s[1]) + (s[2] + s[3]);
    }
    let mid = (a.len() / 2).div_ceil(LEAF) * LEAF;
    let (al, ar) = a.split_at(mid);
    let (bl, br) = b.split_at(mid);
    let (l, r) = rayon::join(|| dot(al, bl), || dot(ar, br));
    l + r
}

/// `Σ_{k ∈ range} f(k)` by a fixed binary split into 4096-term leaves, each summed in order
/// with four interleaved partial sums (term `k` into partial `k mod 4`, counted from the
/// leaf's start): the summation tree depends only on the range, so the result is bitwise
/// independent of the thread count; the partial sums break the one chain of additions whose
/// latency bounds a plain sequential sum.
pub(crate) fn tree_sum(range: std::ops::Range<usize>, f: &(impl Fn(usize) -> f64 + Sync)) -> f64 {
    const LEAF: usize = 4096;
    let len = range.end - range.start;
    if len <= LEAF {
        let mut s = [0.0; 4];
        let mut k = range.start;
        while k + 4 <= range.end {
            for (l, sl) in s.iter_mut().enumerate() {
                *sl += f(k + l);
            }
            k += 4;
        }
        for (l, kk) in (k..range.end).enumerate() {
            s[l] += f(kk);
        }
        return (s[0] + s[1]) + (s[2] + s[3]);
    }
    let mid = range.start + (len / 2).div_ceil(LEAF) * LEAF;
    let (a, b) = rayon::join(
        || tree_sum(range.start..mid, f),
        || tree_sum(mid..range.end, f),
    );
    a + b
}

pub(super) fn axpy_into(out: &mut [f64], a: &[f64], alpha: f64, b: &[f64]) {
    out.par_iter_mut()
        .zip(a.par_iter().zip(b.par_iter()))
        .with_min_len(4096)
        .for_each(|(o, (a, b))| {
            *o = a + alpha * b;
        });
}

impl LinearSolver for BiCgStab {
    fn name(&self) -> &'static str {
        match self.precond {
            Preconditioner::Jacobi => "bicgstab+jacobi",
            Preconditioner::Ilu0 => "bicgstab+ilu0",
            Preconditioner::Amg => "bicgstab+amg",
        }
    }

    fn solve(
        &mut self,
        a: &CsrSystem<'_>,
        x: &mut [f64],
        params: &SolveParams,
    ) -> Result<SolveInfo, SolveError> {
        super::krylov_solve(self, a, x, params)
    }

    fn invalidate_setup(&mut self) {
        self.state.invalidate();
    }

    fn next_solve_is_fresh(&self) -> bool {
        self.state.next_setup_is_fresh(self.precond)
    }
}

impl Krylov for BiCgStab {
    fn precond(&self) -> Preconditioner {
        self.precond
    }
    fn parts(&mut self) -> (&mut PrecondState, &mut Vec<f64>) {
        (&mut self.state, &mut self.x0)
    }

    fn iterate(
        &mut self,
        a: &CsrSystem<'_>,
        x: &mut [f64],
        params: &SolveParams,
        bnorm: f64,
        t0: Instant,
    ) -> Result<SolveInfo, SolveError> {
        let name = self.name();
        let n = a.n();
        // The products with A check its columns once, not at every entry.
        let op = Operator::new(a);
        let setup_seconds = t0.elapsed().as_secs_f64();
        for w in self.work.iter_mut() {
            w.resize(n, 0.0);
        }
        let [r, r0, p, v, s, t, y] = &mut self.work;
        // r = b − A x
        op.matvec(x, t);
        axpy_into(r, a.rhs, -1.0, t);
        r0.copy_from_slice(r);
        let tol = params.rel_tolerance * bnorm;
        let (mut rho, mut alpha, mut omega) = (1.0, 1.0, 1.0);
        p.fill(0.0);
        v.fill(0.0);
        let mut iterations = 0;
        let mut rnorm = dot(r, r).sqrt();
        let mut restarts = 0;
        // An inner product that vanishes or overflows ends the iteration with the iterate it
        // has reached (x is only updated with finite steps), which is then judged like any
        // other (below): a residual stagnating at round-off makes them vanish (or, through a
        // tiny ω, overflow), and is then either accepted as a backward error or reported as not
        // converged, with the residual reached.
        let mut stalled = None;
        while rnorm > tol && iterations < params.max_iterations {
            iterations += 1;
            let rho_new = dot(r0, r);
            if !rho_new.is_finite() {
                stalled = Some("ρ = (r̂₀, r) is not finite");
                break;
            }
            // (r̂₀, r) ≈ 0 with r ≠ 0: the shadow residual has become orthogonal. Restart with
            // r̂₀ = r (a standard remedy), at most MAX_RESTARTS times.
            if rho_new.abs() <= 1e-14 * dot(r0, r0).sqrt() * rnorm {
                if restarts == MAX_RESTARTS {
                    stalled = Some("ρ = (r̂₀, r) vanished (after restarts)");
                    break;
                }
                restarts += 1;
                r0.copy_from_slice(r);
                p.fill(0.0);
                v.fill(0.0);
                (rho, alpha, omega) = (1.0, 1.0, 1.0);
                iterations -= 1;
                continue;
            }
            let beta = (rho_new / rho) * (alpha / omega);
            rho = rho_new;
            // p = r + β (p − ω v)
            p.par_iter_mut()
                .zip(r.par_iter().zip(v.par_iter()))
                .with_min_len(4096)
                .for_each(|(p, (r, v))| *p = r + beta * (*p - omega * v));
            // y = M⁻¹ p, v = A y
            self.state.apply(self.precond, a, p, y);
            op.matvec(y, v);
            let r0v = dot(r0, v);
            if !r0v.is_finite() {
                stalled = Some("(r̂₀, v) is not finite");
                break;
            }
            if r0v == 0.0 {
                stalled = Some("(r̂₀, v) vanished");
                break;
            }
            alpha = rho / r0v;
            // x += α y; s = r − α v
            x.par_iter_mut()
                .zip(y.par_iter())
                .with_min_len(4096)
                .for_each(|(x, y)| *x += alpha * y);
            axpy_into(s, r, -alpha, v);
            let snorm = dot(s, s).sqrt();
            if snorm <= tol {
                break;
            }
            // y = M⁻¹ s, t = A y
            self.state.apply(self.precond, a, s, y);
            op.matvec(y, t);
            let tt = dot(t, t);
            if !tt.is_finite() {
                stalled = Some("(t, t) is not finite");
                break;
            }
            if tt == 0.0 {
                stalled = Some("(t, t) vanished");
                break;
            }
            omega = dot(t, s) / tt;
            x.par_iter_mut()
                .zip(y.par_iter())
                .with_min_len(4096)
                .for_each(|(x, y)| *x += omega * y);
            axpy_into(r, s, -omega, t);
            rnorm = dot(r, r).sqrt();
            if omega == 0.0 {
                stalled = Some("ω vanished");
                break;
            }
        }
        let rel_residual = a.rel_residual(x, t);
        if !rel_residual.is_finite() {
            return Err(SolveError::Breakdown {
                solver: name,
                iterations,
                reason: "non-finite residual",
            });
        }
        // Allow a small slack for recurrence/true residual mismatch, and a residual at the
        // round-off floor (backward error); beyond them, report failure.
        if !a.accepts(x, rel_residual, params.rel_tolerance, t) {
            return Err(SolveError::NoConvergence {
                solver: name,
                iterations,
                rel_residual,
                tolerance: params.rel_tolerance,
                stalled,
            });
        }
        Ok(SolveInfo {
            iterations,
            rel_residual,
            seconds: t0.elapsed().as_secs_f64(),
            setup_seconds,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `tree_sum` equals the exact sum of every term (integers, exact in any order; the terms
    /// at `k` are distinct, so a dropped, repeated or misplaced term changes the sum) for
    /// ranges around the leaf and lane boundaries, with a non-zero start; and on
    /// floating-point terms gives the same bits on one thread and on three.
    #[test]
    fn tree_sum_adds_each_term_once_and_is_thread_count_independent() {
        for len in [0, 1, 3, 4, 5, 7, 4095, 4096, 4097, 8193, 3 * 4096 + 5] {
            for start in [0, 13] {
                let range = start..start + len;
                let sum = tree_sum(range.clone(), &|k| (k * k % 1009 + k) as f64);
                let exact: usize = range.map(|k| k * k % 1009 + k).sum();
                assert_eq!(sum, exact as f64, "len {len}, start {start}");
            }
        }
        let f = |k: usize| ((k as f64) * 0.618_033_988_749).sin() / (1.0 + k as f64);
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool")
                .install(|| tree_sum(5..20_000, &f))
        };
        let (one, three) = (on(1), on(3));
        assert_eq!(one.to_bits(), three.to_bits());
        let plain: f64 = (5..20_000).map(f).sum();
        assert!(
            (one - plain).abs() <= 1e-12 * plain.abs(),
            "{one} against {plain}"
        );
    }

    /// `dot` is `tree_sum` of the products, bit for bit, at lengths around the lanes and the
    /// leaves (so the vectorised leaf keeps the tree's order), on one thread and on three.
    /// (Equal bits here need not catch a wrong association inside a leaf when rounding happens
    /// to agree; `the_leaf_sums_in_the_documented_order` pins that.)
    #[test]
    fn dot_is_the_tree_sum_of_the_products() {
        for n in [0, 1, 3, 4, 5, 6, 7, 4095, 4096, 4097, 3 * 4096 + 7, 20_001] {
            let a: Vec<f64> = (0..n)
                .map(|k| ((k as f64) * 0.37).sin() * 1e8f64.powi((k % 3) as i32))
                .collect();
            let b: Vec<f64> = (0..n).map(|k| 1.0 / (1.0 + k as f64).sqrt()).collect();
            let tree = tree_sum(0..n, &|k| a[k] * b[k]);
            for threads in [1, 3] {
                let d = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .expect("a thread pool")
                    .install(|| dot(&a, &b));
                assert_eq!(d.to_bits(), tree.to_bits(), "n {n}, {threads} threads");
            }
        }
    }

    /// The leaf's association written out by hand: terms 0 and 4 in partial sum 0, 1 and 5 in
    /// 1, 2 in 2, 3 in 3, then (s₀ + s₁) + (s₂ + s₃). With 1e16 (whose ulp is 2) a lone 1 added
    /// to it rounds away (ties to even), so s₀ = 1e16, s₁ = 2, s₂ + s₃ = −1e16 and the sum is
    /// 2; a remainder term in the wrong partial sum gives 0, a left-to-right combine 3.
    #[test]
    fn the_leaf_sums_in_the_documented_order() {
        let a = [1e16, 1.0, -1e16, 1.0, 1.0, 1.0];
        let b = [1.0; 6];
        assert_eq!(dot(&a, &b), 2.0);
        assert_eq!(tree_sum(0..6, &|k| a[k]), 2.0);
    }
}
