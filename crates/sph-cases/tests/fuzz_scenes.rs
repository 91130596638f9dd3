//! A seeded fuzz of scene parsing and validation: 100 000 inputs made by mutating the scenes in
//! `cases/` (numbers swapped for extreme values, keys renamed, lines deleted, duplicated,
//! swapped or spliced from another scene, values of the wrong type, stray bytes, blocks moved
//! into each other or out of their container) go through
//! everything `dgsph check` does before running — parse, validate (also the quick preset),
//! budget estimate, step count, simulation settings — and, for small valid scenes, the
//! particle set itself. None may panic.
//!
//! It is a property test rather than a cargo-fuzz target so that it runs on the stable
//! toolchain in CI; the generator is deterministic (seed below), so a failure reproduces.

use sph_cases::reference::References;
use sph_cases::registry;
use std::panic::{AssertUnwindSafe, catch_unwind};

const SCENES: [(&str, &str); 16] = [
    (
        "cavity_cube_3d",
        include_str!("../../../cases/cavity_cube_3d.toml"),
    ),
    (
        "cavity_density",
        include_str!("../../../cases/cavity_density.toml"),
    ),
    (
        "cavity_density_quintic",
        include_str!("../../../cases/cavity_density_quintic.toml"),
    ),
    (
        "cavity_re100",
        include_str!("../../../cases/cavity_re100.toml"),
    ),
    (
        "cavity_re400",
        include_str!("../../../cases/cavity_re400.toml"),
    ),
    (
        "cavity_re1000",
        include_str!("../../../cases/cavity_re1000.toml"),
    ),
    (
        "dam_break",
        include_str!("../../../cases/hard/dam_break.toml"),
    ),
    (
        "dam_break_3d",
        include_str!("../../../cases/hard/dam_break_3d.toml"),
    ),
    (
        "drop_on_wall",
        include_str!("../../../cases/hard/drop_on_wall.toml"),
    ),
    (
        "drop_into_pool",
        include_str!("../../../cases/hard/drop_into_pool.toml"),
    ),
    (
        "dam_break_obstacle",
        include_str!("../../../cases/hard/dam_break_obstacle.toml"),
    ),
    (
        "elliptical_drop",
        include_str!("../../../cases/elliptical_drop.toml"),
    ),
    (
        "prescribed_ellipse",
        include_str!("../../../cases/prescribed_ellipse.toml"),
    ),
    (
        "prescribed_ellipsoid",
        include_str!("../../../cases/prescribed_ellipsoid.toml"),
    ),
    (
        "spheroid_drop",
        include_str!("../../../cases/spheroid_drop.toml"),
    ),
    (
        "taylor_green",
        include_str!("../../../cases/hard/taylor_green.toml"),
    ),
];

const INPUTS: usize = 100_000;

/// Values that break naive code: zeros, signs, extremes, subnormals, non-finite, huge
/// integers, fractions that do not divide a box.
const NASTY: [&str; 28] = [
    "0",
    "-0.0",
    "-1",
    "1",
    "2",
    "3",
    "0.5",
    "0.03",
    "1e-4",
    "1e-7",
    "1e-12",
    "1e-300",
    "5e-324",
    "1e308",
    "-1e308",
    "1e20",
    "nan",
    "inf",
    "-inf",
    "+inf",
    "4294967297",
    "18446744073709551615",
    "-9223372036854775808",
    "99999999999999999999",
    "1.0e",
    "0x10",
    "1_000",
    "07",
];

/// Values of the wrong type or shape.
const WRONG: [&str; 12] = [
    "\"text\"",
    "\"\"",
    "true",
    "[]",
    "[1]",
    "[1, 2, 3, 4]",
    "[[1, 2]]",
    "{}",
    "{ a = 1 }",
    "1979-05-27",
    "[\"x\", \"x\"]",
    "\"d2\"",
];

/// Stray text inserted at random.
const STRAY: [&str; 14] = [
    "[",
    "]",
    "{",
    "}",
    "=",
    "\"",
    "'",
    "#",
    ",",
    "\n",
    "[[fluid]]\n",
    "[effects]\n",
    "\u{0}",
    "é",
];

/// splitmix64: a small deterministic generator (no dependency needed for a test).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a>(&mut self, xs: &[&'a str]) -> &'a str {
        xs[self.below(xs.len())]
    }
}

/// Byte ranges of the numbers in `s` (a digit run with sign, point and exponent).
fn numbers(s: &str) -> Vec<(usize, usize)> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || (matches!(b[i], b'-' | b'+') && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        if starts && (i == 0 || !b[i - 1].is_ascii_alphanumeric() && b[i - 1] != b'_') {
            let j0 = i;
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_digit()
                    || matches!(b[i], b'.' | b'e' | b'E')
                    || (matches!(b[i], b'-' | b'+') && matches!(b[i - 1], b'e' | b'E')))
            {
                i += 1;
            }
            out.push((j0, i));
        } else {
            i += 1;
        }
    }
    out
}

/// Keys used anywhere in the scenes (left of `=`).
fn keys() -> Vec<String> {
    let mut k: Vec<String> = SCENES
        .iter()
        .flat_map(|(_, t)| t.lines())
        .filter_map(|l| l.split_once('=').map(|(k, _)| k.trim().to_string()))
        .filter(|k| !k.is_empty() && !k.starts_with('#') && !k.contains(' '))
        .collect();
    k.sort();
    k.dedup();
    k
}

/// One to four mutations of `text`.
fn mutate(rng: &mut Rng, text: &str, keys: &[String]) -> String {
    let mut s = text.to_string();
    for _ in 0..1 + rng.below(4) {
        let lines: Vec<&str> = s.lines().collect();
        s = match rng.below(10) {
            0 | 1 => {
                // A number replaced by a nasty value.
                let ns = numbers(&s);
                if ns.is_empty() {
                    continue;
                }
                let (a, b) = ns[rng.below(ns.len())];
                format!("{}{}{}", &s[..a], rng.pick(&NASTY), &s[b..])
            }
            2 => {
                // A value replaced by one of the wrong type.
                let with_value: Vec<usize> = (0..lines.len())
                    .filter(|&i| lines[i].contains('='))
                    .collect();
                if with_value.is_empty() {
                    continue;
                }
                let i = with_value[rng.below(with_value.len())];
                let key = lines[i].split_once('=').map_or("", |(k, _)| k);
                let mut l: Vec<String> = lines.iter().map(|x| x.to_string()).collect();
                l[i] = format!("{key}= {}", rng.pick(&WRONG));
                l.join("\n")
            }
            3 => {
                // A key renamed to another scene key (maybe a duplicate, maybe in the wrong table).
                let with_value: Vec<usize> = (0..lines.len())
                    .filter(|&i| lines[i].contains('='))
                    .collect();
                if with_value.is_empty() {
                    continue;
                }
                let i = with_value[rng.below(with_value.len())];
                let value = lines[i].split_once('=').map_or("", |(_, v)| v);
                let mut l: Vec<String> = lines.iter().map(|x| x.to_string()).collect();
                l[i] = format!("{} ={value}", keys[rng.below(keys.len())]);
                l.join("\n")
            }
            4 => {
                // A line deleted.
                let mut l = lines.clone();
                if !l.is_empty() {
                    l.remove(rng.below(l.len()));
                }
                l.join("\n")
            }
            5 => {
                // A line duplicated or moved.
                let mut l = lines.clone();
                if l.is_empty() {
                    continue;
                }
                let i = rng.below(l.len());
                let line = l[i];
                if rng.below(2) == 0 {
                    l.remove(i);
                }
                let j = rng.below(l.len() + 1);
                l.insert(j, line);
                l.join("\n")
            }
            6 => {
                // A line spliced in from another scene.
                let other = SCENES[rng.below(SCENES.len())].1;
                let ol: Vec<&str> = other.lines().collect();
                let mut l = lines.clone();
                let j = rng.below(l.len() + 1);
                l.insert(j, ol[rng.below(ol.len())]);
                l.join("\n")
            }
            7 => {
                // Stray text at a random character boundary.
                let cut = (0..=s.len())
                    .filter(|&i| s.is_char_boundary(i))
                    .nth(rng.below(s.len() + 1))
                    .unwrap_or(0);
                format!("{}{}{}", &s[..cut], rng.pick(&STRAY), &s[cut..])
            }
            8 => {
                // A block moved: every number of one `min`, `max` or `center` line shifted by
                // the same offset, so that it overlaps another block, leaves its container or
                // its periodic box.
                let corners: Vec<usize> = (0..lines.len())
                    .filter(|&i| {
                        let k = lines[i].trim_start();
                        k.starts_with("min") || k.starts_with("max") || k.starts_with("center")
                    })
                    .collect();
                if corners.is_empty() {
                    continue;
                }
                let i = corners[rng.below(corners.len())];
                let offset: f64 =
                    [-100.0, -3.0, -1.0, -0.5, 0.25, 0.5, 1.0, 3.0, 1e300][rng.below(9)];
                let line = lines[i];
                let mut moved = String::new();
                let mut last = 0;
                for (a, b) in numbers(line) {
                    moved.push_str(&line[last..a]);
                    let v: f64 = line[a..b].parse().unwrap_or(0.0);
                    moved.push_str(&format!("{:?}", v + offset));
                    last = b;
                }
                moved.push_str(&line[last..]);
                let mut l: Vec<String> = lines.iter().map(|x| x.to_string()).collect();
                l[i] = moved;
                l.join("\n")
            }
            _ => {
                // The file cut short.
                let cut = (0..=s.len())
                    .filter(|&i| s.is_char_boundary(i))
                    .nth(rng.below(s.len() + 1))
                    .unwrap_or(0);
                s[..cut].to_string()
            }
        };
    }
    s
}

/// What `dgsph check` does with a scene text before running anything. `build`: also build the
/// particle set when the scene is small.
fn check(text: &str, build: bool) -> Result<bool, String> {
    let scene = registry::parse_scene("fuzz", text).map_err(|e| e.to_string())?;
    let quick = scene.quick();
    registry::validate(&quick, "fuzz (quick)").map_err(|e| e.to_string())?;
    for s in [&scene, &quick] {
        let e = s.estimate();
        let _ = (s.steps(), s.sim_config(), s.diagnostics(), e.particles());
        if build && e.particles() < 3000.0 {
            registry::particle_counts(s, References::embedded()).map_err(|e| e.to_string())?;
        }
    }
    Ok(true)
}

#[test]
fn a_hundred_thousand_mutated_scenes_never_panic() {
    let keys = keys();
    let mut rng = Rng(0x5eed_d95f_0000_0016);
    let (mut valid, mut refused, mut panics) = (0usize, 0usize, Vec::new());
    let mut messages = std::collections::BTreeSet::new();
    std::panic::set_hook(Box::new(|_| {}));
    for k in 0..INPUTS {
        let (name, base) = SCENES[rng.below(SCENES.len())];
        let text = mutate(&mut rng, base, &keys);
        let build = k % 20 == 0;
        match catch_unwind(AssertUnwindSafe(|| check(&text, build))) {
            Ok(Ok(_)) => valid += 1,
            Ok(Err(m)) => {
                refused += 1;
                if messages.len() < 100_000 {
                    messages.insert(m.lines().next().unwrap_or("").to_string());
                }
            }
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                panics.push(format!("input {k} (from {name}): {msg}\n{text}"));
            }
        }
    }
    let _ = std::panic::take_hook();
    println!(
        "{INPUTS} inputs: {valid} valid, {refused} refused with a typed error ({} distinct first lines), {} panics",
        messages.len(),
        panics.len()
    );
    assert!(
        panics.is_empty(),
        "{} panics; first:\n{}",
        panics.len(),
        panics[..panics.len().min(3)].join("\n====\n")
    );
    assert_eq!(valid + refused, INPUTS);
    // The generator exercises both paths: many inputs are refused, and many still pass.
    assert!(
        refused > INPUTS / 4 && valid > INPUTS / 20,
        "valid {valid}, refused {refused}"
    );
}
