//! What every xtask integration test needs (as `crates/dgsph/tests/common` for `dgsph`): a
//! scratch directory and a run of the real binary.
#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// An empty directory under the system's temporary directory, named after `name` and this
/// process (tests run in parallel and may be re-run).
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dgsph-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The xtask binary Cargo built for these tests, as a command to add arguments to.
pub fn xtask_command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
}

/// Runs `command`: its exit code, its standard output followed by its standard error, and the
/// raw output.
pub fn run(command: &mut Command) -> (Option<i32>, String, Output) {
    let o = command.output().unwrap();
    let text =
        String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    (o.status.code(), text, o)
}

/// Runs the xtask binary with `args`, as [`run`].
pub fn xtask(args: &[&str]) -> (Option<i32>, String, Output) {
    run(xtask_command().args(args))
}
