//! # dgsph (the command)
//!
//! The `dgsph` binary and the code it shares with `cargo xtask`: everything that touches files,
//! the terminal and exit codes. The library crates below do no I/O; this crate reads scenes,
//! runs them through `sph_cases`' run loop and writes what they produce.
//!
//! * [`session`] — run a scene: every scheme, checkpoints and the resume rule, progress,
//!   the run summary with its pass breakdown, exit codes.
//! * [`output`] — the files of a run (CSV records, MCAP, tables, checkpoints, ParaView).
//! * [`vtk`] — ParaView `.vtp` frames and the `.pvd` index.
//! * [`summary`] — the typed `summary.json` and `<run>.run.json`.
//! * [`report`] — `report.md` and its SVG figures from an output directory.
//! * [`signals`] — SIGINT and SIGTERM stop a run after its step, with a checkpoint.
//!
//! Start with [`session::run_scene`].

pub mod cli;
pub mod mcap_sink;
pub mod output;
pub mod overrides;
pub mod report;
pub mod session;
pub mod signals;
pub mod summary;
pub mod vtk;

/// `println!` that ignores a closed or failing stdout (`dgsph run … | head -1`): the run goes
/// on and writes its files; only the terminal lines are lost.
#[macro_export]
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// `print!` that ignores a closed or failing stdout (see [`say!`]).
#[macro_export]
macro_rules! say_part {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

/// `eprintln!` that ignores a closed or failing stderr (see [`say!`]).
#[macro_export]
macro_rules! warn {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// The revision of the working tree (`git rev-parse HEAD`, with `-dirty` if it has changes),
/// or `"unknown"`.
pub fn git_revision() -> String {
    let run = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match run(&["rev-parse", "HEAD"]) {
        Some(rev) if run(&["status", "--porcelain"]).is_some_and(|s| !s.is_empty()) => {
            format!("{rev}-dirty")
        }
        Some(rev) => rev,
        None => "unknown".to_string(),
    }
}
