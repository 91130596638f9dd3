//! A minimal FFI to hypre (BoomerAMG as a preconditioner of hypre's BiCGSTAB and PCG) on one
//! MPI rank, for comparing our multigrid with it on the same matrices (feature `hypre`; needs
//! Debian's `libhypre-dev`, which brings Open MPI). Only what the comparison uses is declared;
//! the types are those of the Debian build (`HYPRE_Int` = `int`, `HYPRE_Real` = `double`, no
//! big integers — checked against `/usr/include/hypre/HYPRE_config.h`).

use std::ffi::{c_char, c_int, c_void};
use std::ptr;

type HypreInt = c_int;
type Handle = *mut c_void;
type MpiComm = *mut c_void;
type SolverFn = unsafe extern "C" fn(Handle, Handle, Handle, Handle) -> HypreInt;

const HYPRE_PARCSR: HypreInt = 5555;

#[link(name = "mpi")]
unsafe extern "C" {
    static mut ompi_mpi_comm_world: u8;
    fn MPI_Init(argc: *mut c_int, argv: *mut *mut *mut c_char) -> c_int;
    fn MPI_Initialized(flag: *mut c_int) -> c_int;
}

#[link(name = "HYPRE")]
unsafe extern "C" {
    fn HYPRE_IJMatrixCreate(
        comm: MpiComm,
        il: HypreInt,
        iu: HypreInt,
        jl: HypreInt,
        ju: HypreInt,
        m: *mut Handle,
    ) -> HypreInt;
    fn HYPRE_IJMatrixSetObjectType(m: Handle, t: HypreInt) -> HypreInt;
    fn HYPRE_IJMatrixInitialize(m: Handle) -> HypreInt;
    fn HYPRE_IJMatrixSetValues(
        m: Handle,
        nrows: HypreInt,
        ncols: *const HypreInt,
        rows: *const HypreInt,
        cols: *const HypreInt,
        values: *const f64,
    ) -> HypreInt;
    fn HYPRE_IJMatrixAssemble(m: Handle) -> HypreInt;
    fn HYPRE_IJMatrixGetObject(m: Handle, o: *mut Handle) -> HypreInt;
    fn HYPRE_IJMatrixDestroy(m: Handle) -> HypreInt;
    fn HYPRE_IJVectorCreate(comm: MpiComm, jl: HypreInt, ju: HypreInt, v: *mut Handle) -> HypreInt;
    fn HYPRE_IJVectorSetObjectType(v: Handle, t: HypreInt) -> HypreInt;
    fn HYPRE_IJVectorInitialize(v: Handle) -> HypreInt;
    fn HYPRE_IJVectorSetValues(
        v: Handle,
        n: HypreInt,
        idx: *const HypreInt,
        values: *const f64,
    ) -> HypreInt;
    fn HYPRE_IJVectorGetValues(
        v: Handle,
        n: HypreInt,
        idx: *const HypreInt,
        values: *mut f64,
    ) -> HypreInt;
    fn HYPRE_IJVectorAssemble(v: Handle) -> HypreInt;
    fn HYPRE_IJVectorGetObject(v: Handle, o: *mut Handle) -> HypreInt;
    fn HYPRE_IJVectorDestroy(v: Handle) -> HypreInt;
    fn HYPRE_BoomerAMGCreate(s: *mut Handle) -> HypreInt;
    fn HYPRE_BoomerAMGDestroy(s: Handle) -> HypreInt;
    fn HYPRE_BoomerAMGSetup(s: Handle, a: Handle, b: Handle, x: Handle) -> HypreInt;
    fn HYPRE_BoomerAMGSolve(s: Handle, a: Handle, b: Handle, x: Handle) -> HypreInt;
    fn HYPRE_BoomerAMGSetTol(s: Handle, tol: f64) -> HypreInt;
    fn HYPRE_BoomerAMGSetMaxIter(s: Handle, n: HypreInt) -> HypreInt;
    fn HYPRE_BoomerAMGSetPrintLevel(s: Handle, n: HypreInt) -> HypreInt;
    fn HYPRE_ParCSRBiCGSTABCreate(comm: MpiComm, s: *mut Handle) -> HypreInt;
    fn HYPRE_ParCSRBiCGSTABDestroy(s: Handle) -> HypreInt;
    fn HYPRE_ParCSRBiCGSTABSetup(s: Handle, a: Handle, b: Handle, x: Handle) -> HypreInt;
    fn HYPRE_ParCSRBiCGSTABSolve(s: Handle, a: Handle, b: Handle, x: Handle) -> HypreInt;
    fn HYPRE_ParCSRBiCGSTABSetTol(s: Handle, tol: f64) -> HypreInt;
    fn HYPRE_ParCSRBiCGSTABSetMaxIter(s: Handle, n: HypreInt) -> HypreInt;
    fn HYPRE_ParCSRBiCGSTABSetPrecond(
        s: Handle,
        p: SolverFn,
        ps: SolverFn,
        pre: Handle,
    ) -> HypreInt;
    fn HYPRE_ParCSRBiCGSTABGetNumIterations(s: Handle, n: *mut HypreInt) -> HypreInt;
    fn HYPRE_ParCSRPCGCreate(comm: MpiComm, s: *mut Handle) -> HypreInt;
    fn HYPRE_ParCSRPCGDestroy(s: Handle) -> HypreInt;
    fn HYPRE_ParCSRPCGSetup(s: Handle, a: Handle, b: Handle, x: Handle) -> HypreInt;
    fn HYPRE_ParCSRPCGSolve(s: Handle, a: Handle, b: Handle, x: Handle) -> HypreInt;
    fn HYPRE_ParCSRPCGSetTol(s: Handle, tol: f64) -> HypreInt;
    fn HYPRE_ParCSRPCGSetMaxIter(s: Handle, n: HypreInt) -> HypreInt;
    fn HYPRE_ParCSRPCGSetTwoNorm(s: Handle, n: HypreInt) -> HypreInt;
    fn HYPRE_ParCSRPCGSetPrecond(s: Handle, p: SolverFn, ps: SolverFn, pre: Handle) -> HypreInt;
    fn HYPRE_ParCSRPCGGetNumIterations(s: Handle, n: *mut HypreInt) -> HypreInt;
}

fn world() -> MpiComm {
    // Open MPI's MPI_COMM_WORLD is the address of this predefined object.
    ptr::addr_of_mut!(ompi_mpi_comm_world).cast()
}

/// Initialises MPI once (one rank).
pub fn init() {
    unsafe {
        let mut flag = 0;
        MPI_Initialized(&mut flag);
        if flag == 0 {
            MPI_Init(ptr::null_mut(), ptr::null_mut());
        }
    }
}

/// The Krylov method around BoomerAMG.
#[derive(Clone, Copy, Debug)]
pub enum Krylov {
    /// Preconditioned conjugate gradients (symmetric matrices).
    Pcg,
    /// BiCGSTAB.
    BiCgStab,
}

/// What one hypre solve took.
#[derive(Clone, Copy, Debug)]
pub struct Outcome {
    /// Krylov iterations.
    pub iterations: usize,
    /// Seconds in the Krylov and BoomerAMG setup.
    pub setup_s: f64,
    /// Seconds in the solve.
    pub solve_s: f64,
}

/// Solves the CSR system `A x = b` (x from zero) with `krylov` + one BoomerAMG V-cycle (hypre's
/// defaults) to relative residual `tol`; returns the iterations and times, writes `x`.
pub fn solve(
    offsets: &[usize],
    cols: &[u32],
    values: &[f64],
    b: &[f64],
    x: &mut [f64],
    tol: f64,
    krylov: Krylov,
) -> Outcome {
    let n = b.len();
    let hi = n as HypreInt - 1;
    let ncols: Vec<HypreInt> = offsets
        .windows(2)
        .map(|w| (w[1] - w[0]) as HypreInt)
        .collect();
    let rows: Vec<HypreInt> = (0..n as HypreInt).collect();
    let cols_i: Vec<HypreInt> = cols.iter().map(|c| *c as HypreInt).collect();
    let zero = vec![0.0; n];
    unsafe {
        let comm = world();
        let (mut ij_a, mut a) = (ptr::null_mut(), ptr::null_mut());
        HYPRE_IJMatrixCreate(comm, 0, hi, 0, hi, &mut ij_a);
        HYPRE_IJMatrixSetObjectType(ij_a, HYPRE_PARCSR);
        HYPRE_IJMatrixInitialize(ij_a);
        HYPRE_IJMatrixSetValues(
            ij_a,
            n as HypreInt,
            ncols.as_ptr(),
            rows.as_ptr(),
            cols_i.as_ptr(),
            values.as_ptr(),
        );
        HYPRE_IJMatrixAssemble(ij_a);
        HYPRE_IJMatrixGetObject(ij_a, &mut a);
        let vector = |data: &[f64]| {
            let (mut ij, mut v) = (ptr::null_mut(), ptr::null_mut());
            HYPRE_IJVectorCreate(comm, 0, hi, &mut ij);
            HYPRE_IJVectorSetObjectType(ij, HYPRE_PARCSR);
            HYPRE_IJVectorInitialize(ij);
            HYPRE_IJVectorSetValues(ij, n as HypreInt, rows.as_ptr(), data.as_ptr());
            HYPRE_IJVectorAssemble(ij);
            HYPRE_IJVectorGetObject(ij, &mut v);
            (ij, v)
        };
        let (ij_b, hb) = vector(b);
        let (ij_x, hx) = vector(&zero);
        let mut amg = ptr::null_mut();
        HYPRE_BoomerAMGCreate(&mut amg);
        HYPRE_BoomerAMGSetPrintLevel(amg, 0);
        HYPRE_BoomerAMGSetTol(amg, 0.0);
        HYPRE_BoomerAMGSetMaxIter(amg, 1);
        let mut it: HypreInt = 0;
        let mut s = ptr::null_mut();
        let t0 = std::time::Instant::now();
        match krylov {
            Krylov::Pcg => {
                HYPRE_ParCSRPCGCreate(comm, &mut s);
                HYPRE_ParCSRPCGSetTol(s, tol);
                HYPRE_ParCSRPCGSetTwoNorm(s, 1);
                HYPRE_ParCSRPCGSetMaxIter(s, 2000);
                HYPRE_ParCSRPCGSetPrecond(s, HYPRE_BoomerAMGSolve, HYPRE_BoomerAMGSetup, amg);
                HYPRE_ParCSRPCGSetup(s, a, hb, hx);
            }
            Krylov::BiCgStab => {
                HYPRE_ParCSRBiCGSTABCreate(comm, &mut s);
                HYPRE_ParCSRBiCGSTABSetTol(s, tol);
                HYPRE_ParCSRBiCGSTABSetMaxIter(s, 2000);
                HYPRE_ParCSRBiCGSTABSetPrecond(s, HYPRE_BoomerAMGSolve, HYPRE_BoomerAMGSetup, amg);
                HYPRE_ParCSRBiCGSTABSetup(s, a, hb, hx);
            }
        }
        let setup_s = t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        match krylov {
            Krylov::Pcg => {
                HYPRE_ParCSRPCGSolve(s, a, hb, hx);
                HYPRE_ParCSRPCGGetNumIterations(s, &mut it);
                HYPRE_ParCSRPCGDestroy(s);
            }
            Krylov::BiCgStab => {
                HYPRE_ParCSRBiCGSTABSolve(s, a, hb, hx);
                HYPRE_ParCSRBiCGSTABGetNumIterations(s, &mut it);
                HYPRE_ParCSRBiCGSTABDestroy(s);
            }
        }
        let solve_s = t1.elapsed().as_secs_f64();
        HYPRE_IJVectorGetValues(ij_x, n as HypreInt, rows.as_ptr(), x.as_mut_ptr());
        HYPRE_BoomerAMGDestroy(amg);
        HYPRE_IJVectorDestroy(ij_b);
        HYPRE_IJVectorDestroy(ij_x);
        HYPRE_IJMatrixDestroy(ij_a);
        Outcome {
            iterations: it as usize,
            setup_s,
            solve_s,
        }
    }
}
