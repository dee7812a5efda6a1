//! `thermcomp demo`: the whole job on the default machine, end to end.
//!
//! One run of `demo --quick --json` (the test build is unoptimised: the
//! full budgets take ~2 min there, `--quick` ~15 s; a release build of the
//! full demo takes ~5 s), checked stage by stage.

mod common;

use common::{fails_one_line, p, run};
use serde_json::Value;
use std::path::Path;

/// Floor for the best model's held-out reduction on the validation run.
/// Measured: 99.6 % (arx, `--quick`), 99.5 % (arx, full budgets), and mlr
/// on the same sensors 99.4 %. The twin's dz is a linear dynamic function of
/// node temperatures that the selected sensors track within 0.02 K of noise,
/// so any working trainer removes nearly all of it; 95 % leaves room for
/// budget and seed changes, and still fails when selection picks sensors
/// that do not see the spindle (ambient, coolant: ~0 %) or scoring breaks.
const REDUCTION_FLOOR_PCT: f64 = 95.0;

/// Half the 0.1 um step of an offset in a CAN frame.
const HALF_STEP_UM: f64 = 0.05;

fn f(v: &Value, what: &str) -> f64 {
    let x = v
        .as_f64()
        .unwrap_or_else(|| panic!("{what} is not a number: {v}"));
    assert!(x.is_finite(), "{what} = {x}");
    x
}

fn non_empty_file(dir: &Path, rel: &str) {
    let path = dir.join(rel);
    let len = std::fs::metadata(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .len();
    assert!(len > 0, "{} is empty", path.display());
}

#[test]
fn demo_runs_every_stage_and_writes_its_files() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("out");
    let out = run(&["demo", "--out", p(&dir), "--json", "--quick"]);
    let (so, se) = (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    );
    assert!(out.status.success(), "demo failed: {se}");
    let d: Value = serde_json::from_str(&so).unwrap_or_else(|e| panic!("not JSON ({e}): {so}"));
    // Progress on stderr, one header per stage; stdout is the JSON alone.
    for n in 1..=6 {
        assert!(se.contains(&format!("[{n}/6]")), "no stage {n} line: {se}");
    }
    let shown = std::fs::canonicalize(&dir).unwrap();
    assert!(se.contains(p(&shown)), "stderr does not say where: {se}");
    for stage in ["simulate", "select", "fit", "export", "replay", "diagnose"] {
        assert!(d[stage].is_object(), "no stage {stage}");
        f(&d[stage]["elapsed_s"], &format!("{stage}.elapsed_s"));
    }

    // 1. Two runs of the default machine.
    for run in ["calibration", "validation"] {
        let r = &d["simulate"][run];
        assert_eq!(r["rows"], 721, "{run}: 12 h at 60 s");
        let dz = f(&r["max_abs_dz_um"], "max_abs_dz_um");
        assert!(dz > 10.0, "{run}: the spindle barely grew ({dz} um)");
    }

    // 2. Sensors picked by both methods, all of them used.
    let sel = &d["select"];
    let selected: Vec<&str> = sel["selected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(!selected.is_empty());
    for m in ["maxtree", "grey"] {
        for s in sel["methods"][m].as_array().unwrap() {
            assert!(
                selected.contains(&s.as_str().unwrap()),
                "{m} pick {s} unused"
            );
        }
    }

    // 3. Every kind fitted and validated; auto exported (chosen on the
    //    calibration run), arma labelled and never chosen.
    let models = d["fit"]["models"].as_array().unwrap();
    let kinds: Vec<&str> = models.iter().map(|m| m["kind"].as_str().unwrap()).collect();
    assert_eq!(
        kinds,
        ["auto", "mlr", "pcr", "arx", "tf", "bp", "gabp", "arma"]
    );
    for m in models {
        let k = m["kind"].as_str().unwrap();
        for key in ["rmse_um", "fit_pct", "max_abs_um", "reduction_pct"] {
            f(&m["validation"][key], &format!("{k} validation {key}"));
            f(&m["calibration"][key], &format!("{k} calibration {key}"));
        }
        assert_eq!(
            m["validation"]["n"], 721,
            "{k}: scored on the whole validation run"
        );
        assert_eq!(m["forecaster"], Value::Bool(k == "arma"), "{k}");
        non_empty_file(&dir, &format!("models/{k}.bin"));
    }
    let best = d["fit"]["best"].as_str().unwrap();
    assert_eq!(best, "auto");
    let best_m = models.iter().find(|m| m["kind"] == best).unwrap();
    let reduction = f(&best_m["validation"]["reduction_pct"], "best reduction");
    assert!(
        reduction >= REDUCTION_FLOOR_PCT,
        "best ({best}) held-out reduction {reduction} % < {REDUCTION_FLOOR_PCT} %"
    );
    // The honest baseline on the same split: plain least squares on the
    // selected sensors. Auto's cross-validation picks an ARX model over its
    // filter-bank ridge on both demos, beyond the CV noise, and beats the
    // baseline: 99.61 vs 99.34 % on the full demo (24 h at 30 s), 99.61 vs
    // 99.38 % on --quick's 12 h at 60 s (release build). The ridge alone
    // was 0.55 to 0.82 points behind on --quick (98.83 / 98.56 %, release /
    // debug: 720 samples and 14 inputs, where the hand-picked sensors
    // extrapolate to the step profile better), so 1 point below the
    // baseline stays the floor; a worse auto fails.
    let mlr = models.iter().find(|m| m["kind"] == "mlr").unwrap();
    let mlr_red = f(&mlr["validation"]["reduction_pct"], "mlr reduction");
    assert!(
        reduction >= mlr_red - 1.0,
        "auto {reduction} % < mlr {mlr_red} % - 1"
    );

    // 4. The best blob exported, byte for byte the one fitted.
    let ex = &d["export"];
    assert_eq!(ex["kind"], best);
    let blob = std::fs::read(dir.join("model.bin")).unwrap();
    assert_eq!(
        blob,
        std::fs::read(dir.join(format!("models/{best}.bin"))).unwrap()
    );
    assert_eq!(ex["bytes"], blob.len());
    assert!(ex["crc32"].as_str().unwrap().starts_with("0x"));

    // 5. Firmware in the loop: every sample running, a frame set each, and
    //    the offsets sent within the frame's half step of the host model
    //    run on the hub's own readings, wherever no limiter acted.
    let r = &d["replay"];
    let samples = r["samples"].as_u64().unwrap();
    assert_eq!(samples, 721);
    assert_eq!(r["states"]["running"], samples);
    assert!(
        r["frames"].as_u64().unwrap() >= 2 * samples,
        "offsets + status each sample"
    );
    let compared = r["compared_samples"].as_u64().unwrap();
    assert_eq!(compared + r["limited_samples"].as_u64().unwrap(), samples);
    assert!(
        compared >= samples * 9 / 10,
        "only {compared} unlimited samples"
    );
    let agree = f(&r["max_abs_sent_minus_model_um"], "replay agreement");
    assert!(agree <= HALF_STEP_UM + 1e-9, "sent vs model: {agree} um");
    // On the logged temperatures the PT100 quantisation (<= 0.016 K) adds
    // a few tenths of a um through the model's gains; bounded loosely.
    let on_file = f(&r["max_abs_sent_minus_model_on_file_um"], "on file");
    assert!(on_file < 1.0, "sent vs model on the file: {on_file} um");

    // 6. The sim-to-real gap: the withheld effect is found.
    let g = &d["diagnose"];
    assert_eq!(g["withheld"], "ambient");
    assert_eq!(
        g["verdict"], "ambient",
        "diagnose missed the withheld effect: {}",
        g["result"]
    );
    assert_eq!(g["found_withheld"], true);
    let shrink = f(&g["best_shrink_pct"], "best shrink");
    assert!(shrink > 50.0, "best shrink {shrink} %");
    f(&g["rms_before_um"], "rms_before");
    f(&g["rms_after_um"], "rms_after");

    // Every file there, and listed.
    let files: Vec<&str> = d["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    for rel in [
        "calibration.csv",
        "validation.csv",
        "model.bin",
        "model.txt",
        "replay.log",
        "replay-trace.csv",
        "diagnose/sim.csv",
        "diagnose/real.csv",
        "diagnose/report/index.html",
        "fit/index.html",
    ] {
        non_empty_file(&dir, rel);
        assert!(files.contains(&rel), "{rel} not listed in files");
    }

    // The text summary (what `demo` prints without --json) has a line per stage.
    let typed: host_tools::demo::DemoOutcome =
        serde_json::from_value(d.clone()).expect("demo --json reads back as the typed outcome");
    let text = host_tools::demo::summary_text(&typed);
    for (n, stage) in ["simulate", "select", "fit", "export", "replay", "diagnose"]
        .iter()
        .enumerate()
    {
        assert!(
            text.contains(&format!("{} {stage}", n + 1)),
            "no {stage} line:\n{text}"
        );
    }
    assert!(
        text.contains("<- exported") && text.contains("forecaster"),
        "{text}"
    );
}

#[test]
fn demo_fails_in_one_line_when_it_cannot_write() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("a_file");
    std::fs::write(&file, "x").unwrap();
    let se = fails_one_line(&["demo", "--out", p(&file.join("sub")), "--quick"]);
    assert!(se.contains("output folder"), "{se}");
}
