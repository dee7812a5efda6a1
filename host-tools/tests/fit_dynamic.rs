//! `thermcomp fit --model arx|tf|gain` end to end on synthetic runs driven
//! by a known TF bank (seed 004's form: a spindle temperature and ambient),
//! and the ARX fit on the real FL_THERMAL spindle run.

mod common;

use common::{
    ok as thermcomp, ok_json as json, run, write, FL_THERMAL as REAL_RUN,
    SYNTHETIC_SPINDLE as SYNTHETIC_RUN,
};
use serde_json::Value;
use std::fmt::Write as _;

/// Sample time of the synthetic runs (s).
const DT: f64 = 10.0;
/// Truth: spindle entry 12 um/K, tau 3000 s; ambient entry -8 um/K, tau 6000 s.
const K_SP: f64 = 12.0;
const TAU_SP: f64 = 3000.0;
const K_AMB: f64 = -8.0;
const TAU_AMB: f64 = 6000.0;

/// Exact (zero-order-hold) discretisation of `K / (tau s + 1)`: `(a, b)`
/// with `y(k) = p y(k-1) + K (1 - p) u(k-1)`.
fn first_order(k: f64, tau: f64) -> ([f64; 2], [f64; 2]) {
    let p = (-DT / tau).exp();
    ([0.0, k * (1.0 - p)], [1.0, -p])
}

/// 24 h at 10 s: a speed staircase heats T1 (first order, 1200 s, 2 mK/rpm);
/// ambient is two slow sinusoids; `dz_um` is the known bank with the spindle
/// part scaled by `spindle_gain`, plus white noise of `noise_um` (uniform,
/// deterministic LCG). Returns the CSV text.
fn synthetic(spindle_gain: f64, noise_um: f64) -> String {
    let n = (24.0 * 3600.0 / DT) as usize;
    let levels = [0.0, 3000.0, 6000.0, 1500.0, 4500.0, 0.0, 5000.0, 2000.0];
    let (a1, b1) = first_order(K_SP, TAU_SP);
    let (a2, b2) = first_order(K_AMB, TAU_AMB);
    let p_t = (-DT / 1200.0).exp();
    let mut lcg: u64 = 0x2545_f491_4f6c_dd1d;
    let mut csv = String::from("t_s,speed_rpm,T1,ambient_c,dz_um\n");
    let (mut t1, mut y1, mut y2) = (22.0, 0.0, 0.0);
    let (mut u1_prev, mut u2_prev, mut speed_prev) = (0.0, 0.0, 0.0);
    let amb = |t: f64| {
        20.0 + 1.5 * (2.0 * std::f64::consts::PI * t / 86400.0).sin()
            + 0.7 * (2.0 * std::f64::consts::PI * t / 17000.0 + 1.0).sin()
    };
    let amb0 = amb(0.0);
    for k in 0..n {
        let t = k as f64 * DT;
        let speed = levels[(k * 8 / n * 3 + k / 270) % levels.len()];
        if k > 0 {
            t1 = p_t * t1 + (1.0 - p_t) * (22.0 + 2e-3 * speed_prev);
        }
        let (u1, u2) = (t1 - 22.0, amb(t) - amb0);
        if k > 0 {
            y1 = -b1[1] * y1 + a1[1] * u1_prev;
            y2 = -b2[1] * y2 + a2[1] * u2_prev;
        }
        lcg = lcg
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let e = ((lcg >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0 * noise_um;
        let y = spindle_gain * y1 + y2 + e;
        writeln!(csv, "{t},{speed},{t1:.6},{:.6},{y:.6}", amb(t)).unwrap();
        (u1_prev, u2_prev, speed_prev) = (u1, u2, speed);
    }
    csv
}

fn step_gain(eq: &Value, input: &str) -> f64 {
    eq["inputs"][input]["step"]["gain_per_unit"]
        .as_f64()
        .unwrap()
}

fn step_tau(eq: &Value, input: &str) -> f64 {
    eq["inputs"][input]["step"]["tau_s"].as_f64().unwrap()
}

/// Asserts `got` is within `rel` of `want`, relatively; `what` names it.
fn assert_close(got: f64, want: f64, rel: f64, what: &str) {
    assert!((got - want).abs() < rel * want.abs(), "{what} {got}");
}

/// The held-out `key` of `dz_um` in a fit report.
fn holdout(j: &Value, key: &str) -> f64 {
    j["targets"]["dz_um"]["holdout"][key].as_f64().unwrap()
}

/// `fit <model_args>` of `dz_um` from T1 and ambient on the synthetic run
/// `data`, holding out from 16 h, writing `out`.
fn fit_bank(model_args: &[&str], data: &str, out: &str) -> Value {
    json(&fit_bank_args(model_args, data, out))
}

/// The arguments of [`fit_bank`].
fn fit_bank_args<'a>(model_args: &[&'a str], data: &'a str, out: &'a str) -> Vec<&'a str> {
    let mut args = vec!["fit"];
    args.extend_from_slice(model_args);
    args.extend([
        "--data",
        data,
        "--target",
        "dz_um",
        "--inputs",
        "T1,ambient_c",
        "--holdout-from-s",
        "57600",
        "--out",
        out,
        "--json",
    ]);
    args
}

fn fit_synthetic(kind: &str, noise_um: f64) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "run.csv", &synthetic(1.0, noise_um));
    let out = dir.path().join("m.bin").display().to_string();
    fit_bank(&["--model", kind], &data, &out)
}

#[test]
fn arx_identifies_a_known_bank() {
    // Noise-free (only the CSV's 6 decimals): the true structure (na 2,
    // nb 2 or more, nk 1 or less) is in the search and is found; gains and
    // time constants within 0.5 %.
    let j = fit_synthetic("arx", 0.0);
    let table = j["details"]["search"]["table"].as_array().unwrap();
    // Default ranges: 4 x 3 x 3 orders x 7 ridge penalties, each with a row.
    assert_eq!(table.len(), 4 * 3 * 3 * 7);
    for row in table {
        // Every kept candidate is stable (unstable ones have no fit).
        if !row["mean_sim_fit_pct"].is_null() {
            assert_eq!(row["stable"], true);
        }
    }
    let eq = &j["details"]["equations"]["dz_um"];
    for (input, k, tau) in [("T1", K_SP, TAU_SP), ("ambient_c", K_AMB, TAU_AMB)] {
        assert_close(step_gain(eq, input), k, 5e-3, &format!("{input} gain"));
        assert_close(step_tau(eq, input), tau, 5e-3, &format!("{input} tau"));
    }
    let fit = holdout(&j, "fit_pct");
    assert!(fit > 99.0, "held-out fit {fit}");
}

#[test]
fn arx_under_output_noise_is_biased_but_close() {
    // 0.05 um white noise on y: ARX's equation error makes the noise a
    // regressor error (y(k-1), y(k-2) change by ~0.01 um per 10 s step), so
    // the poles are biased: measured 11.93 um/K (spindle) and -6.86 um/K
    // (ambient, the weakly excited one), held-out fit 86 %. Bounds: 3 %,
    // 20 %, 80 %. This is why `--model tf` (output error) exists.
    let j = fit_synthetic("arx", 0.05);
    let eq = &j["details"]["equations"]["dz_um"];
    assert_close(step_gain(eq, "T1"), K_SP, 0.03, "T1 gain");
    assert_close(step_gain(eq, "ambient_c"), K_AMB, 0.2, "ambient gain");
    let fit = holdout(&j, "fit_pct");
    assert!(fit > 80.0, "held-out fit {fit}");
}

#[test]
fn tf_identifies_a_known_bank() {
    let j = fit_synthetic("tf", 0.05);
    let eq = &j["details"]["targets"]["dz_um"];
    assert!(!eq["search"]["table"].as_array().unwrap().is_empty());
    // Output error is unbiased under white output noise: gains within 2 %,
    // time constants within 5 %.
    assert_close(step_gain(eq, "T1"), K_SP, 0.02, "T1 gain");
    assert_close(step_gain(eq, "ambient_c"), K_AMB, 0.02, "ambient gain");
    assert_close(step_tau(eq, "T1"), TAU_SP, 0.05, "T1 tau");
    assert_close(step_tau(eq, "ambient_c"), TAU_AMB, 0.05, "ambient tau");
    let fit = holdout(&j, "fit_pct");
    assert!(fit > 97.0, "held-out fit {fit}");
}

#[test]
fn gain_recovers_a_scaled_spindle_part() {
    let dir = tempfile::tempdir().unwrap();
    let (a1, b1) = first_order(K_SP, TAU_SP);
    let (a2, b2) = first_order(K_AMB, TAU_AMB);
    let spec = format!(
        "kind = \"tf\"\ndt_s = {DT}\n\n[[tf]]\noutput = \"dz_um\"\ninput = \"T1\"\nreference = \"first\"\na = {a1:?}\nb = {b1:?}\n\n[[tf]]\noutput = \"dz_um\"\ninput = \"ambient_c\"\nreference = \"first\"\na = {a2:?}\nb = {b2:?}\n"
    );
    let spec = write(dir.path(), "sp1.toml", &spec);
    let base = dir.path().join("sp1.bin").display().to_string();
    thermcomp(&["model", "build", "--spec", &spec, "--out", &base]);
    // Another spindle unit: the same machine, its spindle part 1.37 times larger.
    let data = write(dir.path(), "sp2.csv", &synthetic(1.37, 0.0));
    let out = dir.path().join("sp2.bin").display().to_string();
    let j = fit_bank(&["--model", "gain", "--gain-from", &base], &data, &out);
    // Noise-free, the same structure: g to 1e-3 (the CSV's 6 decimals limit it).
    let g = j["details"]["gain"].as_f64().unwrap();
    assert!((g - 1.37).abs() < 1e-3, "g = {g}");
    let before = j["details"]["before"]["dz_um"]["holdout"]["rmse_um"]
        .as_f64()
        .unwrap();
    let after = holdout(&j, "rmse_um");
    assert!(after < 0.1 * before, "held-out rmse {before} -> {after}");
    let red = holdout(&j, "reduction_pct");
    assert!(red > 99.0, "held-out reduction {red}");
}

#[test]
fn gain_needs_the_models_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "run.csv", &synthetic(1.0, 0.0));
    let out = run(&[
        "fit",
        "--model",
        "gain",
        "--data",
        &data,
        "--target",
        "dz_um",
        "--inputs",
        "T1",
        "--out",
        "/dev/null",
    ]);
    let se = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success() && se.contains("--gain-from"), "{se}");
}

#[test]
fn arx_on_the_real_spindle_run() {
    // Inputs by a stated rule (docs/fit.md): the NC spindle speed plus the
    // three temperatures most correlated with ch1 over the first 24 h.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ch1.bin").display().to_string();
    let t0 = std::time::Instant::now();
    let j = json(&[
        "fit",
        "--model",
        "arx",
        "--data",
        REAL_RUN,
        "--target",
        "ch1_um",
        "--inputs",
        "speed_rpm,T6,T10,T14",
        "--holdout-from-s",
        "86400",
        "--out",
        &out,
        "--json",
    ]);
    let held = &j["targets"]["ch1_um"]["holdout"];
    let red = held["reduction_pct"].as_f64().unwrap();
    eprintln!(
        "real run, arx ch1: held-out reduction {red:.1} %, fit {:.1} %, chosen {}, {:.2} s",
        held["fit_pct"],
        j["details"]["chosen"],
        t0.elapsed().as_secs_f64()
    );
    // Measured 67.1 % (release; 67.7 % under the old tail search); a floor
    // well under it catches a broken fit.
    assert!(red > 55.0, "held-out reduction {red}");
}

fn fit_dz(extra: &[&str]) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.bin").display().to_string();
    let mut args = vec![
        "fit",
        "--data",
        SYNTHETIC_RUN,
        "--target",
        "dz_um",
        "--holdout-from-s",
        "86400",
        "--out",
        &out,
        "--json",
    ];
    args.extend_from_slice(extra);
    json(&args)
}

#[test]
fn forward_selection_on_the_synthetic_spindle() {
    // Truth (scripts/synthetic_run.py): dz = -(3.2 lag(T1, 20 min) + 1.8 T4
    // + 0.9 T5 - 2.5 lag(T6, 2 h)). Over the calibration day T1 swings ~7 K
    // and T4 ~5 K; T6 (ambient) only ~2 K and it is in every sensor: T1
    // carries the largest term, so it must come first, and T8 (unrelated)
    // must never be taken. The ambient term is hard to tell apart from the
    // others within 6 h folds: measured, selection stops after T1
    // (T4 adds less than --min-gain-pct 1) with held-out fit 82.4 %, BELOW
    // the MLR on all 8 sensors (86.5 %); ARX on all 8 gives 92.8 %. This test
    // pins that finding (docs/fit.md) rather than the hoped-for T1 + T6.
    let sel = fit_dz(&["--model", "arx", "--select-inputs", "forward"]);
    let s = &sel["details"]["selection"];
    let picked: Vec<&str> = s["selected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(picked.first(), Some(&"T1"), "{s}");
    assert!(!picked.contains(&"T8"), "{s}");
    let path = s["path"].as_array().unwrap();
    assert!(path[0]["search_fit_pct"].as_f64().unwrap() > 90.0, "{s}");
    let held = |j: &Value| holdout(j, "fit_pct");
    let mlr = held(&fit_dz(&["--model", "mlr"]));
    let all = held(&fit_dz(&["--model", "arx"]));
    eprintln!(
        "synthetic dz: forward {picked:?} {:.1} %, arx all {all:.1} %, mlr {mlr:.1} %",
        held(&sel)
    );
    assert!(held(&sel) > 75.0, "forward held-out fit {}", held(&sel));
    assert!(all > mlr + 3.0, "arx all {all} vs mlr {mlr}");
}

#[test]
fn a_run_of_one_row_is_left_out_with_a_note() {
    // A second run of one row has no span to resample: it cannot enter the
    // grid, and the fit says so rather than dropping it silently. The blob
    // is the one fitted on the first run alone (same held-out rmse to
    // 1e-12 um: the one row changes nothing).
    let dir = tempfile::tempdir().unwrap();
    let text = synthetic(1.0, 0.0);
    let data = write(dir.path(), "run.csv", &text);
    let one: String = text.lines().take(2).map(|l| format!("{l}\n")).collect();
    let single = write(dir.path(), "single.csv", &one);
    let out = dir.path().join("m.bin").display().to_string();
    let alone = fit_bank(&["--model", "arx"], &data, &out);
    // The one-row run first (so the sample time is given: the first run's
    // median step is the default), before a kept run.
    let (so, se) = thermcomp(&fit_bank_args(
        &["--model", "arx", "--dt-s", "10", "--data", &single],
        &data,
        &out,
    ));
    assert!(
        se.contains("single.csv has no 10 s sample") && se.contains("it is left out"),
        "{se}"
    );
    let both: Value = serde_json::from_str(&so).unwrap();
    let (a, b) = (holdout(&alone, "rmse_um"), holdout(&both, "rmse_um"));
    assert!((a - b).abs() < 1e-12, "{a} vs {b}");
}
