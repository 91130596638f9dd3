//! Our smoothed-aggregation AMG (BiCGSTAB) against hypre's BoomerAMG (BiCGSTAB and PCG) on the
//! same pressure matrices: the PPE of a 2D block of water on a perturbed lattice (quintic,
//! h = 1.3 dx), with its free surface as Dirichlet rows, and the same block closed (no
//! Dirichlet row: singular, constants in the null space). One thread, x from zero, relative
//! residual 1e-8. Ours solves the closed block under the bordered mean-zero gauge (as a run
//! does); hypre gets the singular matrix with the mean removed from the right-hand side.
//!
//! `cargo run --release -p dgsph-benches --features hypre --bin amg_compare` (needs
//! `libhypre-dev`); prints a markdown table with the true residual of hypre's answers, and
//! exits with 1 if one of our solves failed (CI runs it at 10⁴ as a smoke test).
//! `AMG_COMPARE_SIZES=10000,40000` chooses the sizes, `AMG_COMPARE_OURS_ONLY=1` skips hypre.

use dgsph_benches::{Block, hypre};
use sph_core::{D2, VectorOps};
use sph_pressure::{
    AnySolver, CsrMatrix, CsrSystem, LinearSolver, MeanZeroGauge, SolveError, SolveInfo,
    SolveParams, SolverKind, assemble_ppe,
};

fn main() {
    hypre::init();
    let tol = 1e-8;
    println!("| system | unknowns | solver | iterations | setup (s) | solve (s) | total (s) |");
    println!("|---|---:|---|---:|---:|---:|---:|");
    let sizes: Vec<usize> = std::env::var("AMG_COMPARE_SIZES")
        .ok()
        .map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![10_000, 40_000, 160_000, 640_000]);
    let ours_only = std::env::var_os("AMG_COMPARE_OURS_ONLY").is_some();
    let mut failed = false;
    for n in sizes {
        let block = Block::<D2>::new(n);
        let (pts, nl, ones, div_r, ctx) = (
            &block.pts,
            &block.nl,
            &block.ones,
            &block.div_r,
            block.ctx(),
        );
        let n = pts.len();
        let side = (n as f64).sqrt();
        let src: Vec<f64> = pts
            .iter()
            .map(|x| {
                let (u, v) = (x.get(0) / side, x.get(1) / side);
                (std::f64::consts::TAU * u).sin() * (std::f64::consts::TAU * v).cos() + 0.3
            })
            .collect();
        for closed in [false, true] {
            let dirichlet: Vec<bool> = if closed {
                vec![false; n]
            } else {
                div_r.iter().map(|d| *d < 1.5).collect()
            };
            let mut m = CsrMatrix::default();
            let mut rhs = vec![0.0; n];
            assemble_ppe(
                &ctx,
                ones,
                ones,
                &src,
                1.0,
                &dirichlet,
                None,
                rhs.len(),
                &mut m,
                &mut rhs,
            )
            .unwrap();
            let sys = CsrSystem {
                offsets: nl.offsets(),
                cols: nl.indices(),
                values: &m.values,
                rhs: &rhs,
                border: None,
            };
            let name = if closed {
                "closed (gauge)"
            } else {
                "free surface (Dirichlet rows)"
            };
            // Ours.
            let mut solver = AnySolver::new(SolverKind::BicgstabAmg);
            let params = SolveParams {
                rel_tolerance: tol,
                max_iterations: 200,
            };
            let mut x = vec![0.0; n];
            let t0 = std::time::Instant::now();
            let info = if closed {
                MeanZeroGauge::default().solve(&mut solver, &sys, n, &mut x, &params)
            } else {
                solver.solve(&sys, &mut x, &params)
            };
            failed |= !report(name, n, "ours: BiCGSTAB + SA-AMG", info, t0);
            // hypre, and ours on the same singular system (closed: mean removed from b).
            let b: Vec<f64> = if closed {
                let mean = rhs.iter().sum::<f64>() / n as f64;
                rhs.iter().map(|v| v - mean).collect()
            } else {
                rhs.clone()
            };
            if closed {
                let singular = CsrSystem { rhs: &b, ..sys };
                let mut x = vec![0.0; n];
                let t0 = std::time::Instant::now();
                let info = solver.solve(&singular, &mut x, &params);
                failed |= !report(
                    name,
                    n,
                    "ours on the singular matrix, mean-free b",
                    info,
                    t0,
                );
            }
            let krylovs = if ours_only {
                vec![]
            } else {
                vec![hypre::Krylov::BiCgStab, hypre::Krylov::Pcg]
            };
            let mut scratch = vec![0.0; n];
            for krylov in krylovs {
                let mut x = vec![0.0; n];
                let o = hypre::solve(sys.offsets, sys.cols, sys.values, &b, &mut x, tol, krylov);
                // True relative residual of hypre's answer.
                let rel = CsrSystem { rhs: &b, ..sys }.rel_residual(&x, &mut scratch);
                println!(
                    "| {name} | {n} | hypre: {krylov:?} + BoomerAMG (residual {rel:.1e}) | {} | {:.3} | {:.3} | {:.3} |",
                    o.iterations,
                    o.setup_s,
                    o.solve_s,
                    o.setup_s + o.solve_s
                );
            }
        }
    }
    if failed {
        std::process::exit(1);
    }
}

/// Prints the table row of one of our solves (started at `t0`); false if it failed.
fn report(
    name: &str,
    n: usize,
    solver: &str,
    info: Result<SolveInfo, SolveError>,
    t0: std::time::Instant,
) -> bool {
    let total = t0.elapsed().as_secs_f64();
    match info {
        Ok(i) => {
            println!(
                "| {name} | {n} | {solver} | {} | {:.3} | {:.3} | {total:.3} |",
                i.iterations,
                i.setup_seconds,
                total - i.setup_seconds,
            );
            true
        }
        Err(e) => {
            println!("| {name} | {n} | {solver} | failed: {e} | | | |");
            false
        }
    }
}
