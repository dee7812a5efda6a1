//! A dynamic model with a fixed `dt_s` on a run sampled at another rate, or
//! irregularly: `predict` gives every row a prediction (the rows after the
//! last whole model step included), and `eval` and `fit` score every row,
//! with `n` equal to the rows scored.
//!
//! The reference is computed here, independently of the runner: the inputs
//! interpolated linearly onto the model's grid `t0 + k dt_s`, extended by one
//! step past the run's last time with the inputs held at their last values
//! (docs/models.md, "Sampling and missing values"); the difference equation
//! stepped on that grid; and its output interpolated linearly back to the
//! run's own times.

mod common;

use common::{ok, ok_json, write};

/// Model sample time, s.
const DT: f64 = 15.0;
/// `dz_um = (a0 + a1 q^-1) / (1 + b1 q^-1) (T1 - 20)`; binary fractions, so
/// the blob's coefficients are exactly these (steady-state gain 1 um/K).
const A0: f64 = 0.125;
const A1: f64 = 0.0625;
const B1: f64 = -0.8125;
const REFERENCE_C: f64 = 20.0;

/// Predictions are compared with the reference to this many um: the same
/// f64 arithmetic, possibly in another order (outputs are a few um).
const TOL_UM: f64 = 1e-9;

const SPEC: &str = "kind = \"tf\"\ndt_s = 15.0\n\n[[tf]]\noutput = \"dz_um\"\ninput = \"T1\"\nreference = 20.0\na = [0.125, 0.0625]\nb = [1.0, -0.8125]\n";

/// The temperature at time `t` s: a warm-up with a ripple, 20 deg C at t = 0.
fn t1(t: f64) -> f64 {
    REFERENCE_C + 5.0 * (1.0 - (-t / 1200.0).exp()) + 0.3 * (t / 97.0).sin()
}

/// Linear interpolation of `(ts, xs)` at `t` (inside `[ts[0], ts[last]]`).
fn interp(ts: &[f64], xs: &[f64], t: f64) -> f64 {
    let i = ts.partition_point(|&s| s <= t);
    if i == 0 {
        return xs[0];
    }
    if i == ts.len() {
        assert!(t <= ts[i - 1] + 1e-12, "{t} past the end");
        return xs[i - 1];
    }
    let (t0, t1) = (ts[i - 1], ts[i]);
    let w = (t - t0) / (t1 - t0);
    xs[i - 1] * (1.0 - w) + xs[i] * w
}

/// The reference predictions at the run's times `ts` for temperatures `us`.
fn reference(ts: &[f64], us: &[f64]) -> Vec<f64> {
    let (t0, t_end) = (ts[0], *ts.last().unwrap());
    let steps = ((t_end - t0) / DT - 1e-9).ceil() as usize;
    let grid: Vec<f64> = (0..=steps).map(|k| t0 + k as f64 * DT).collect();
    assert!(*grid.last().unwrap() >= t_end);
    let (mut y_prev, mut u_prev) = (0.0, 0.0);
    let y: Vec<f64> = grid
        .iter()
        .map(|&g| {
            let u = interp(ts, us, g.min(t_end)) - REFERENCE_C;
            let y = A0 * u + A1 * u_prev - B1 * y_prev;
            (y_prev, u_prev) = (y, u);
            y
        })
        .collect();
    ts.iter().map(|&t| interp(&grid, &y, t)).collect()
}

/// Writes a run with rows at `ts`: `T1` and a measured `dz_um` (the
/// reference plus a small, known misfit, so the scores are not all zero).
fn write_run(dir: &std::path::Path, name: &str, ts: &[f64]) -> (String, Vec<f64>) {
    let us: Vec<f64> = ts.iter().map(|&t| t1(t)).collect();
    let want = reference(ts, &us);
    let mut csv = String::from("t_s,T1,dz_um\n");
    for ((t, u), y) in ts.iter().zip(&us).zip(&want) {
        csv.push_str(&format!("{t},{u},{}\n", y + 0.01 * (t / 300.0).cos()));
    }
    (write(dir, name, &csv), want)
}

/// `predict`: one row per input row, every one with a prediction equal to
/// the reference within `TOL_UM`; `eval`: every row scored, `n` = rows,
/// and nothing reported as unscored.
fn check(ts: &[f64]) {
    let dir = tempfile::tempdir().unwrap();
    let spec = write(dir.path(), "m.toml", SPEC);
    let model = dir.path().join("m.bin");
    let model = model.to_str().unwrap();
    ok(&["model", "build", "--spec", &spec, "--out", model]);
    let (run, want) = write_run(dir.path(), "run.csv", ts);
    let pred = dir.path().join("pred.csv");
    let pred = pred.to_str().unwrap();
    let (_, se) = ok(&["predict", "--model", model, "--data", &run, "--out", pred]);
    assert!(se.contains("resampled"), "the resampling is reported: {se}");

    let text = std::fs::read_to_string(pred).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t_s,dz_um_pred"));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), ts.len(), "one row per input row");
    for ((line, &t), w) in rows.iter().zip(ts).zip(&want) {
        let (t_text, v) = line.split_once(',').unwrap();
        assert_eq!(t_text.parse::<f64>().unwrap(), t);
        assert!(!v.is_empty(), "no prediction at t = {t} s");
        let v: f64 = v.parse().unwrap();
        assert!((v - w).abs() <= TOL_UM, "t = {t} s: {v} vs {w}");
    }

    let j = ok_json(&["eval", "--model", model, "--data", &run, "--json"]);
    assert_eq!(j["dz_um"]["n"].as_u64(), Some(ts.len() as u64), "{j}");
    assert_eq!(j["dz_um"]["rows_not_scored"].as_u64(), Some(0), "{j}");
}

#[test]
fn run_every_10_s_with_a_15_s_model_predicts_and_scores_every_row() {
    // 0..590 s: the model's grid 0, 15, .., 585 stops 5 s before the last row.
    let ts: Vec<f64> = (0..60).map(|i| 10.0 * i as f64).collect();
    check(&ts);
}

#[test]
fn irregular_run_predicts_and_scores_every_row() {
    // Steps of 7..13 s, the last row at 597.3 s (12.3 s after the grid's 585).
    let mut ts: Vec<f64> = (0..60)
        .map(|i| 10.0 * i as f64 + 3.0 * (1.7 * i as f64).sin())
        .collect();
    *ts.last_mut().unwrap() = 597.3;
    assert!(ts.windows(2).all(|w| w[1] > w[0]));
    check(&ts);
}

/// `fit` of an ARX at dt 15 s on T1, held out from 3000 s, with `--json`.
fn arx_fit_args<'a>(run: &'a str, out: &'a std::path::Path) -> Vec<&'a str> {
    vec![
        "fit",
        "--data",
        run,
        "--target",
        "dz_um",
        "--inputs",
        "T1",
        "--model",
        "arx",
        "--dt-s",
        "15",
        "--holdout-from-s",
        "3000",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]
}

#[test]
fn fit_on_a_resampled_run_scores_every_row() {
    // An ARX fit at dt 15 s on rows every 10 s: calibration and held-out
    // n add up to every row of the run.
    let dir = tempfile::tempdir().unwrap();
    let ts: Vec<f64> = (0..600).map(|i| 10.0 * i as f64 + 5.0).collect();
    let (run, _) = write_run(dir.path(), "run.csv", &ts);
    let out = dir.path().join("arx.bin");
    let j = ok_json(&arx_fit_args(&run, &out));
    let t = &j["targets"]["dz_um"];
    let n = |part: &str| t[part]["n"].as_u64().unwrap_or_else(|| panic!("{t}"));
    assert_eq!(n("calibration") + n("holdout"), ts.len() as u64, "{t}");
    assert_eq!(
        n("holdout"),
        ts.iter().filter(|&&t| t >= 3000.0).count() as u64
    );
    assert_eq!(t["rows_not_scored"].as_u64(), Some(0), "{t}");
}

#[test]
fn rows_that_cannot_be_scored_are_counted_on_stderr() {
    // Two empty dz_um cells: eval and fit score the other rows, n counts
    // exactly those, and stderr says how many were left out.
    let dir = tempfile::tempdir().unwrap();
    let ts: Vec<f64> = (0..600).map(|i| 10.0 * i as f64).collect();
    let (run, _) = write_run(dir.path(), "full.csv", &ts);
    let text = std::fs::read_to_string(&run).unwrap();
    let holed: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 100 || i == 400 {
                let (rest, _) = l.rsplit_once(',').unwrap();
                format!("{rest},\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let run = write(dir.path(), "holed.csv", &holed);
    let spec = write(dir.path(), "m.toml", SPEC);
    let model = dir.path().join("m.bin");
    let model = model.to_str().unwrap();
    ok(&["model", "build", "--spec", &spec, "--out", model]);
    let (so, se) = ok(&["eval", "--model", model, "--data", &run, "--json"]);
    let j: serde_json::Value = serde_json::from_str(&so).unwrap();
    assert_eq!(j["dz_um"]["n"].as_u64(), Some(598), "{j}");
    assert_eq!(j["dz_um"]["rows_not_scored"].as_u64(), Some(2), "{j}");
    assert!(se.contains("2 of 600 rows not scored"), "{se}");

    let out = dir.path().join("arx.bin");
    let (so, se) = ok(&arx_fit_args(&run, &out));
    let j: serde_json::Value = serde_json::from_str(&so).unwrap();
    let t = &j["targets"]["dz_um"];
    let n = |part: &str| t[part]["n"].as_u64().unwrap_or_else(|| panic!("{t}"));
    assert_eq!(n("calibration") + n("holdout"), 598, "{t}");
    assert_eq!(t["rows_not_scored"].as_u64(), Some(2), "{t}");
    assert!(se.contains("2 of 600 rows not scored"), "{se}");
}
