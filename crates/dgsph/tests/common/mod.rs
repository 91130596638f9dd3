//! Running the `dgsph` binary in a scratch directory.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh scratch directory for one test.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dgsph-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `dgsph <args>`, waited for.
pub fn dgsph(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dgsph"))
        .args(args)
        .env("RAYON_NUM_THREADS", "2")
        .output()
        .unwrap()
}

/// stdout and stderr together.
pub fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr)
}

/// Writes `scene` to `dir/name.toml` and returns the path.
pub fn scene(dir: &Path, name: &str, scene: &str) -> PathBuf {
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, scene).unwrap();
    p
}

/// A 2D lid-driven cavity at 10² (Re 100, shifting) running `t_end / 0.01` steps, its fluid
/// renumbered in cell order every 3 steps (so restarts meet renumbered states).
pub fn cavity(t_end: f64) -> String {
    format!(
        "case = \"lid_driven_cavity\"\ndim = 2\ndx = 0.1\nkernel = \"wendland_c2\"\ndt = 0.01\nt_end = {t_end}\nschemes = [\"euler\", \"predictor_corrector\", \"dg\"]\nsolver_tolerance = 1e-8\nreorder_every = 3\n[cavity]\nreynolds = 100\ncheck_ghia = false\nsnapshots = [0.05]\n[effects]\nshifting = {{ coefficient = 2.0 }}\n"
    )
}

/// The CSV rows of `path` without the wall-clock columns (`*seconds*`), as text.
pub fn rows_without_timing(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&k| !header[k].contains("seconds"))
        .collect();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            keep.iter()
                .map(|&k| f.get(k).copied().unwrap_or(""))
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect()
}
