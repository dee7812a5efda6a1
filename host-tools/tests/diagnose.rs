//! `thermcomp diagnose` on twin runs with known causes: the real run is the
//! twin with one effect on, a different noise seed and a slightly wrong
//! machine (structure heat capacity +4 %, front-bearing heat +4 %); the sim
//! is the nominal twin driven by the real run's own speed and power
//! (`--profile file:REAL.csv`). 48 h at 60 s, spectrum profile. Figures
//! quoted beside the thresholds are from docs/diagnose.md (seeds 1-5).

mod common;

use common::{fails_one_line, ok, ok_json, p};
use host_tools::diagnose::diagnose_files;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The effect names a verdict may take (CONTRACT.md section 3).
const VOCABULARY: [&str; 6] = host_tools::bench::cases::LABELS;

/// The built-in machine with two parameters a few % off: the twin's own
/// model error that the `none` baseline must absorb.
fn mismatched_machine(dir: &Path) -> PathBuf {
    let (toml, _) = ok(&["simulate", "--print-machine"]);
    let changed = toml
        .replace("c_j_per_k = 500000.0", "c_j_per_k = 520000.0")
        .replace(
            "front_bearing_w_at_ref = 250.0",
            "front_bearing_w_at_ref = 260.0",
        );
    assert_ne!(
        changed, toml,
        "the default machine file changed: update the test"
    );
    let path = dir.join("machine.toml");
    std::fs::write(&path, changed).unwrap();
    path
}

/// Writes real (effects on, mismatched machine) and sim (nominal, driven by
/// the real file) runs; optionally drops the ambient_c/coolant_c columns
/// from the real run (a machine that does not log them).
fn runs(dir: &Path, effects: &str, seed: u64, drop_boundaries: bool) -> (PathBuf, PathBuf) {
    let machine = mismatched_machine(dir);
    let real = dir.join("real.csv");
    let sim = dir.join("sim.csv");
    let seed_s = seed.to_string();
    ok(&[
        "simulate",
        "--out",
        p(&real),
        "--hours",
        "48",
        "--dt-s",
        "60",
        "--profile",
        "spectrum",
        "--effects",
        effects,
        "--seed",
        &seed_s,
        "--machine",
        p(&machine),
    ]);
    if drop_boundaries {
        let text = std::fs::read_to_string(&real).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let keep: Vec<usize> = (0..header.len())
            .filter(|&i| header[i] != "ambient_c" && header[i] != "coolant_c")
            .collect();
        let out: String = text
            .lines()
            .map(|l| {
                let cells: Vec<&str> = l.split(',').collect();
                keep.iter().map(|&i| cells[i]).collect::<Vec<_>>().join(",") + "\n"
            })
            .collect();
        std::fs::write(&real, out).unwrap();
    }
    let sim_seed = (seed + 1000).to_string();
    let profile = format!("file:{}", p(&real));
    ok(&[
        "simulate",
        "--out",
        p(&sim),
        "--profile",
        &profile,
        "--seed",
        &sim_seed,
    ]);
    (sim, real)
}

fn diagnose(effects: &str, seed: u64, drop_boundaries: bool) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let (sim, real) = runs(dir.path(), effects, seed, drop_boundaries);
    diagnosed(&sim, &real)
}

/// The library's diagnosis of a pair of files as the JSON object the CLI
/// prints (the contract these tests check).
fn diagnosed(sim: &Path, real: &Path) -> Value {
    let d = diagnose_files(sim, real, None, None).unwrap_or_else(|e| panic!("{e:#}"));
    serde_json::to_value(d).unwrap()
}

fn effect<'a>(v: &'a Value, name: &str) -> &'a Value {
    v["effects"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["name"] == name)
        .unwrap_or_else(|| panic!("no {name} in {v}"))
}

/// The verdict is `name`, its held-out shrink is above `min_shrink_pct`,
/// and no second effect is claimed.
fn identifies(v: &Value, name: &str, min_shrink_pct: f64) {
    assert_eq!(v["verdict"], name, "{v:#}");
    let s = effect(v, name)["shrink_pct"].as_f64().unwrap();
    assert!(s > min_shrink_pct, "{name}: shrink {s} %");
    assert!(v["second"].is_null(), "no second effect: {}", v["second"]);
}

#[test]
fn ambient_is_identified_from_the_logged_ambient() {
    // Measured: 98.2-98.8 % on dz_um.
    let v = diagnose("ambient", 1, false);
    identifies(&v, "ambient", 90.0);
    assert_eq!(v["main_channel"], "dz_um");
    let g = effect(&v, "ambient")["params"]["gain_um_per_k"]
        .as_f64()
        .unwrap();
    assert!(
        g < 0.0,
        "a warmer room grows the machine: dz gain < 0, got {g}"
    );
}

#[test]
fn ambient_is_identified_without_an_ambient_column() {
    // Inferred 24 h cycle; measured 94.4-98.5 %.
    let v = diagnose("ambient", 1, true);
    identifies(&v, "ambient", 85.0);
    assert!(effect(&v, "ambient")["model"]
        .as_str()
        .unwrap()
        .contains("not logged"));
}

#[test]
fn coolant_is_identified_from_the_logged_coolant() {
    // The chiller barely moves dz; the gap shows on T1. Measured 82.3-84.4 %.
    let v = diagnose("coolant", 1, false);
    identifies(&v, "coolant", 70.0);
}

#[test]
fn coolant_without_a_coolant_column_is_tracked_on_a_sensor() {
    // No coolant_c: the chiller cycle is tracked on the temperature channel
    // whose residual carries it (the twin's coolant-supply and jacket
    // sensors), band-passed, never on the explained channel's own hold-out.
    let v = diagnose("coolant", 1, true);
    identifies(&v, "coolant", 40.0);
    let model = effect(&v, "coolant")["model"].as_str().unwrap();
    assert!(model.contains("tracked on T"), "{model}");
    let mid = v["bands"][0]["mid_pct"].as_f64().unwrap();
    assert!(
        mid > 30.0,
        "chiller energy in the 10 min - 2 h band: {mid} %"
    );
}

/// Times (s) at which `x` crosses its mean upwards.
fn up_crossings(t: &[f64], x: &[f64]) -> Vec<f64> {
    let m = x.iter().sum::<f64>() / x.len() as f64;
    (1..x.len())
        .filter(|&k| x[k - 1] < m && x[k] >= m)
        .map(|k| t[k])
        .collect()
}

#[test]
fn a_chiller_whose_period_drifts_with_load_is_found_as_coolant() {
    // A plant of the zoo (not the twin; a development plant) whose chiller
    // tank takes the machine's heat, so its period drifts with the load: a
    // sinusoid fixed on the fit part would not carry over. Found logged
    // (responses to coolant_c) and unlogged (tracked on a sensor); the
    // development zoo found 10 of 10 chiller cases on this plant.
    use host_tools::bench::zoo::inputs::ProfileKind;
    use host_tools::bench::zoo::{cases, ZooCase};
    for (seed, logged) in [(11, true), (12, false), (13, false)] {
        let case = ZooCase {
            id: 0,
            plant: "b".into(),
            effect: "coolant".into(),
            profile: ProfileKind::Spectrum,
            seed,
            magnitude: 1.0,
            logged,
            mismatch_pct: 5.0,
            hours: 48.0,
        };
        let runs = cases::build_runs(&case).unwrap();
        let t: Vec<f64> = (0..runs.real_coolant_c.len())
            .map(|k| 60.0 * k as f64)
            .collect();
        let up = up_crossings(&t, &runs.real_coolant_c);
        let periods: Vec<f64> = up.windows(2).map(|w| w[1] - w[0]).collect();
        let (lo, hi) = periods
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &p| (a.min(p), b.max(p)));
        assert!(hi > 1.3 * lo, "the period drifts: {lo} .. {hi} s");
        let dir = tempfile::tempdir().unwrap();
        let (sim, real) = cases::write_case(&case, dir.path()).unwrap();
        let v = diagnosed(&sim, &real);
        assert_eq!(
            v["verdict"], "coolant",
            "seed {seed}, logged {logged}: {v:#}"
        );
        let c = effect(&v, "coolant")["confidence"].as_f64().unwrap();
        assert!(c >= 0.9, "confidence {c}");
    }
}

#[test]
fn cutting_is_identified_and_localised_in_cutting_regimes() {
    // Measured 97.0-98.2 %.
    let v = diagnose("cutting", 1, false);
    identifies(&v, "cutting", 90.0);
    let top = v["where"][0]["regime"].as_str().unwrap();
    assert!(top.ends_with("cutting"), "{top}");
}

#[test]
fn motor_loss_is_identified_and_localised_at_low_speed() {
    // Measured 59.5-82.7 %; the knee found is the twin's 4000 rpm.
    let v = diagnose("motor_loss", 1, false);
    identifies(&v, "motor_loss", 50.0);
    let top = v["where"][0]["regime"].as_str().unwrap();
    assert!(
        top.contains(" 3000 rpm"),
        "the 25 % speed level carries most of the gap: {top}"
    );
}

#[test]
fn sensor_lag_is_identified_on_a_temperature_channel() {
    // Probes do not lag, so dz shows only noise and the main channel is a
    // sensor on a part. Measured 98.1-98.7 %, tau 600 s as the twin's.
    let v = diagnose("sensor_lag", 1, false);
    identifies(&v, "sensor_lag", 90.0);
    let main = v["main_channel"].as_str().unwrap();
    assert!(main.starts_with('T'), "{main}");
    assert_eq!(effect(&v, "sensor_lag")["params"]["tau_s"], 600.0);
}

#[test]
fn a_model_mismatch_alone_is_no_effect() {
    let v = diagnose("none", 1, false);
    assert_eq!(v["verdict"], "none", "{v:#}");
    assert!(v["second"].is_null());
    // No effect to add: only the model trained on the nominal sim.
    let d = &v["deployment"];
    assert!(d["trained_on_sim"]["rmse_um"].is_number(), "{d}");
    assert!(d["trained_on_sim_plus_effect"].is_null(), "{d}");
}

#[test]
fn deployment_view_a_model_trained_on_sim_plus_the_lag_does_better_on_the_real_run() {
    // Lagging sensors: a model trained on the nominal sim reads prompt
    // sensors, the real machine's lag. Adding the fitted lag to every
    // temperature channel of the sim before training brings the model's
    // real held-out error down. Blind benchmark (docs/diagnose.md,
    // "Deployment"): better in 53 of 53 identified lags on each of three
    // seeds, median 70-74 % lower, worst 11-34 %. This case is a full-size
    // lag on the 48 h spectrum; 25 % is the stated margin, a third of the
    // median.
    let v = diagnose("sensor_lag", 1, false);
    let d = &v["deployment"];
    assert_eq!(d["model"], "mlr");
    assert_eq!(d["target"], "dz_um", "{d}");
    assert_eq!(d["inputs"].as_array().unwrap().len(), 10, "{d}");
    let rmse = |k: &str| {
        d[k]["rmse_um"]
            .as_f64()
            .unwrap_or_else(|| panic!("{k}: {d}"))
    };
    let (sim, eff, real) = (
        rmse("trained_on_sim"),
        rmse("trained_on_sim_plus_effect"),
        rmse("trained_on_real_fit_part"),
    );
    assert!(eff <= 0.75 * sim, "sim {sim} um, sim + lag {eff} um");
    // Real calibration data stays the reference no twin beats here.
    assert!(real < eff, "real {real} um vs sim + lag {eff} um");
}

#[test]
fn two_effects_give_one_of_them_as_the_verdict() {
    // Ambient and a low-speed loss together. The verdict is one of the two;
    // a `second`, if claimed, is the other and leaves <= 0.8 x what the
    // first leaves alone. (With the mismatch baseline the logged ambient
    // alone leaves 0.04 um on dz, under 3 noise sigmas, so the pair search
    // is not asked for.)
    let v = diagnose("ambient,motor_loss", 1, false);
    let verdict = v["verdict"].as_str().unwrap();
    assert!(["ambient", "motor_loss"].contains(&verdict), "{v:#}");
    if let Some(second) = v["second"]["name"].as_str() {
        assert!(second != verdict && ["ambient", "motor_loss"].contains(&second));
        let both = v["second"]["rms_after"].as_f64().unwrap();
        let alone = v["second"]["rms_after_first_alone"].as_f64().unwrap();
        assert!(both <= 0.8 * alone, "{both} vs {alone}");
    }
}

#[test]
fn a_ten_percent_mismatch_alone_is_no_effect() {
    // The twin's eight least certain parameters (heat capacities, losses,
    // the structure's convection and expansion, a conductance) each off by
    // up to +-10 %: the mismatch baseline (gain, time-constant and
    // per-heat-source gain errors) absorbs it. Three seeds; the development
    // twin benchmark at 10 % had no false alarm in 18 `none` cases (6 of 18
    // before the mismatch baseline).
    use host_tools::bench::cases::{write_case, Case, ProfileSpec};
    let nominal = host_tools::twin::machine::Machine::default_machine();
    for seed in [101, 202, 303] {
        let case = Case {
            id: 0,
            effect: "none".into(),
            profile: ProfileSpec::parse("spectrum:48").unwrap(),
            seed,
            magnitude: 0.0,
            logged: true,
            mismatch_pct: 10.0,
        };
        let dir = tempfile::tempdir().unwrap();
        let (sim, real) = write_case(&case, &nominal, dir.path()).unwrap();
        let v = diagnosed(&sim, &real);
        assert_eq!(v["verdict"], "none", "seed {seed}: {v:#}");
    }
}

#[test]
fn json_and_report_follow_the_contract() {
    let dir = tempfile::tempdir().unwrap();
    let (sim, real) = runs(dir.path(), "cutting", 2, false);
    let report = dir.path().join("report");
    let v = ok_json(&[
        "diagnose",
        "--sim",
        p(&sim),
        "--real",
        p(&real),
        "--json",
        "--report",
        p(&report),
    ]);
    let t_end = 47.0 * 3600.0 + 3600.0;
    assert_eq!(v["holdout_from_t_s"].as_f64(), Some(t_end / 2.0));
    for (name, g) in v["gap"].as_object().unwrap() {
        assert!(g["rms"].as_f64().unwrap() >= 0.0, "{name}");
        assert!(
            g["max_abs"].as_f64().unwrap() >= g["rms"].as_f64().unwrap(),
            "{name}"
        );
    }
    for c in ["dx_um", "dy_um", "dz_um", "T1", "T10", "S5"] {
        assert!(v["gap"][c].is_object(), "gap has {c}");
    }
    for w in v["where"].as_array().unwrap() {
        for k in ["channel", "regime"] {
            assert!(w[k].is_string(), "{w}");
        }
        for k in ["from_t_s", "to_t_s", "share_pct"] {
            assert!(w[k].is_number(), "{w}");
        }
    }
    let effects = v["effects"].as_array().unwrap();
    let mut names: Vec<&str> = effects
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    let after: Vec<f64> = effects
        .iter()
        .map(|e| e["rms_after"].as_f64().unwrap())
        .collect();
    assert!(
        after.windows(2).all(|w| w[0] <= w[1]),
        "sorted best first: {after:?}"
    );
    let before = effects[0]["rms_before"].as_f64().unwrap();
    for e in effects {
        assert_eq!(e["rms_before"].as_f64(), Some(before));
        assert!(
            e["shrink_pct"].is_number() && e["params"].is_object(),
            "{e}"
        );
        // A confidence (1 - Holm-adjusted p) and a p-value per candidate;
        // null for the baseline, which is not tested against itself.
        let unit = |k: &str| e[k].as_f64().is_some_and(|x| (0.0..=1.0).contains(&x));
        if e["name"] == "none" {
            assert!(e["confidence"].is_null() && e["p_value"].is_null(), "{e}");
        } else {
            assert!(unit("confidence") && unit("p_value"), "{e}");
        }
    }
    let verdict_conf = effects
        .iter()
        .find(|e| e["name"] == v["verdict"])
        .map(|e| e["confidence"].as_f64().unwrap())
        .unwrap();
    assert!(verdict_conf >= 0.9, "{verdict_conf}");
    names.sort_unstable();
    let mut want = VOCABULARY.to_vec();
    want.sort_unstable();
    assert_eq!(names, want, "every candidate and the none baseline");
    assert!(VOCABULARY.contains(&v["verdict"].as_str().unwrap()));
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("\"verdict\": \"cutting\""));
    assert!(
        html.contains("confidence"),
        "the report shows the confidences"
    );
    assert!(
        html.contains("Deployment") && v["deployment"]["trained_on_sim_plus_effect"].is_object()
    );

    // The same object as the library entry the demo uses.
    let lib = diagnosed(&sim, &real);
    assert_eq!(lib, v);

    // The hold-out time is the user's when given; the text table names the verdict.
    let v = ok_json(&[
        "diagnose",
        "--sim",
        p(&sim),
        "--real",
        p(&real),
        "--json",
        "--holdout-from-s",
        "100000",
    ]);
    assert_eq!(v["holdout_from_t_s"].as_f64(), Some(100000.0));
    let (text, _) = ok(&["diagnose", "--sim", p(&sim), "--real", p(&real)]);
    assert!(text.contains("verdict: cutting"), "{text}");
}

#[test]
fn bad_inputs_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let (sim, real) = runs(dir.path(), "none", 3, false);
    let e = fails_one_line(&[
        "diagnose",
        "--sim",
        p(&sim),
        "--real",
        "/nonexistent/real.csv",
        "--json",
    ]);
    assert!(e.contains("real.csv"), "{e}");
    let e = fails_one_line(&[
        "diagnose",
        "--sim",
        p(&sim),
        "--real",
        p(&real),
        "--holdout-from-s",
        "1e9",
    ]);
    assert!(e.contains("holdout"), "{e}");
    let other = common::write(dir.path(), "other.csv", "t_s,speed_rpm,X\n0,0,1\n1,0,2\n");
    let e = fails_one_line(&["diagnose", "--sim", &other, "--real", p(&real)]);
    assert!(e.contains("no channel"), "{e}");
}
