//! Helpers shared by the `thermcomp` integration tests: run the binary and
//! check its exit status and streams, write files into a temporary
//! directory, and a deterministic noise source. Each test file uses a subset.
#![allow(dead_code)]

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

/// The real spindle run (FL_THERMAL, 46 h, 16 temperatures).
pub const FL_THERMAL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/fl_thermal/run.csv"
);

/// The synthetic spindle run with known physics (scripts/synthetic_run.py).
pub const SYNTHETIC_SPINDLE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../examples/synthetic_spindle.csv"
);

/// Runs `thermcomp` with `args`, whatever its exit status.
pub fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_thermcomp"))
        .args(args)
        .output()
        .expect("thermcomp runs")
}

/// Runs `thermcomp`, asserts it succeeded; returns stdout and stderr.
pub fn ok(args: &[&str]) -> (String, String) {
    let out = run(args);
    let (so, se) = (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    );
    assert!(out.status.success(), "thermcomp {args:?} failed: {se}");
    (so, se)
}

/// As [`ok`], and parses stdout as one JSON value.
pub fn ok_json(args: &[&str]) -> Value {
    let (so, _) = ok(args);
    serde_json::from_str(&so).unwrap_or_else(|e| panic!("not JSON ({e}): {so}"))
}

/// Fails, with exactly one line on stderr, nothing on stdout and no panic;
/// returns stderr.
pub fn fails_one_line(args: &[&str]) -> String {
    let out = run(args);
    let se = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success(), "thermcomp {args:?} should fail");
    assert!(!se.contains("panicked"), "panic: {se}");
    assert_eq!(se.trim_end().lines().count(), 1, "one line: {se}");
    assert!(out.stdout.is_empty(), "nothing on stdout: {:?}", out.stdout);
    se
}

/// A path as the `&str` the command line takes.
pub fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Writes `text` to `dir/name`; returns the path as a string.
pub fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    p(&path).to_string()
}

/// The header of the CSV file at `path` and its rows whose first cell
/// (the time, s) is at least `from_s`.
pub fn rows_from(path: &str, from_s: f64) -> (String, Vec<String>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .filter(|l| l.split(',').next().unwrap().parse::<f64>().unwrap() >= from_s)
        .map(str::to_string)
        .collect();
    (header, rows)
}

/// AR(1) noise, phi 0.99, stationary sd `sd` (xorshift64 + Box-Muller):
/// the slow, correlated wander of real thermal residuals.
pub fn ar1(n: usize, sd: f64, seed: u64) -> Vec<f64> {
    let phi: f64 = 0.99;
    let mut e = 0.0;
    white(n, 1.0, seed)
        .into_iter()
        .map(|z| {
            e = phi * e + sd * (1.0 - phi * phi).sqrt() * z;
            e
        })
        .collect()
}

/// White Gaussian noise of sd `sd` (xorshift64 + Box-Muller): a sensor's
/// own noise.
pub fn white(n: usize, sd: f64, seed: u64) -> Vec<f64> {
    let mut s = seed;
    let mut uni = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| sd * (-2.0 * uni().ln()).sqrt() * (2.0 * std::f64::consts::PI * uni()).cos())
        .collect()
}
