//! The whole user workflow of training, on the synthetic spindle run with
//! known physics (examples/synthetic_spindle.csv, scripts/synthetic_run.py):
//! select sensors, fit mlr, pcr and arx on the first 24 h, check the held-out
//! figures, check that the blob is what `model show`, `predict` and `eval`
//! accept and that `eval` agrees with `fit`'s held-out figures, then refit
//! on a changed run.

mod common;

use common::{ok, ok_json, p, rows_from, write, SYNTHETIC_SPINDLE as RUN};
use std::path::Path;

/// The held-out part of the run only, so `eval` scores what `fit` held out
/// (inputs as changes: the excerpt must keep the run's first row, which
/// carries the references, so the excerpt is the first row plus t >= 24 h).
fn holdout_excerpt(dir: &Path) -> String {
    let (header, later) = rows_from(RUN, 86400.0);
    let text = std::fs::read_to_string(RUN).unwrap();
    let first = text.lines().nth(1).unwrap();
    let out = format!("{header}\n{first}\n{}\n", later.join("\n"));
    write(dir, "holdout.csv", &out)
}

#[test]
fn select_fit_show_predict_eval_refit() {
    let dir = tempfile::tempdir().unwrap();
    // Select: the known physics drives dz_um by T1 (bearing), T4 (housing),
    // T5 (column) and T6 (ambient); T8 is an unrelated sensor and must not
    // be the sole pick of a method that ranks by relation to the target.
    let sel = ok_json(&[
        "select", "--data", RUN, "--target", "dz_um", "--method", "maxtree", "--json",
    ]);
    let chosen: Vec<String> = sel["selected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    assert!(!chosen.is_empty() && chosen != ["T8"], "{chosen:?}");

    // Fit every kind on the first 24 h of all eight sensors.
    let mut held = std::collections::BTreeMap::new();
    // (tf is exercised in fit_dynamic.rs; its Levenberg-Marquardt search on
    // eight inputs takes minutes in a debug build.)
    for kind in ["mlr", "pcr", "arx"] {
        let out = dir.path().join(format!("{kind}.bin"));
        let v = ok_json(&[
            "fit",
            "--data",
            RUN,
            "--target",
            "dz_um",
            "--model",
            kind,
            "--holdout-from-s",
            "86400",
            "--out",
            p(&out),
            "--json",
        ]);
        let h = v["targets"]["dz_um"]["holdout"].clone();
        held.insert(kind, h["reduction_pct"].as_f64().unwrap());
        // The blob is accepted by show, predict and eval.
        ok_json(&["model", "show", "--model", p(&out), "--json"]);
        let pred = dir.path().join(format!("{kind}.csv"));
        ok(&[
            "predict",
            "--model",
            p(&out),
            "--data",
            RUN,
            "--out",
            p(&pred),
        ]);
        let rows = std::fs::read_to_string(&pred).unwrap().lines().count();
        assert_eq!(rows, 1 + 4321, "{kind}: row for row");
        // eval on the whole run agrees with fit's figures over all rows:
        // the same runner scores both (n = calibration + held-out rows).
        let e = ok_json(&["eval", "--model", p(&out), "--data", RUN, "--json"]);
        let n_fit =
            v["targets"]["dz_um"]["calibration"]["n"].as_u64().unwrap() + h["n"].as_u64().unwrap();
        assert_eq!(e["dz_um"]["n"].as_u64().unwrap(), n_fit, "{kind}");
    }
    // Held-out reduction: the physics is linear in lagged temperatures with
    // 0.3 um noise on ~40 um of error, so a static regression already removes
    // most of it (>= 90 %) and the dynamic models at least as much within
    // 3 points (they must spend parameters on the lags).
    assert!(held["mlr"] > 90.0, "{held:?}");
    assert!(held["arx"] > held["mlr"] - 3.0, "{held:?}");

    // The excerpt scored by eval matches fit's held-out figure for MLR
    // (static, so the excerpt needs only the first row for the references).
    let excerpt = holdout_excerpt(dir.path());
    let e = ok_json(&[
        "eval",
        "--model",
        p(&dir.path().join("mlr.bin")),
        "--data",
        &excerpt,
        "--json",
    ]);
    let r = e["dz_um"]["per_run"][0]["reduction_pct"].as_f64().unwrap();
    // One extra row (t = 0, where prediction and measurement are both ~0)
    // moves the mean |y| and |r| by under 0.1 %.
    assert!(
        (r - held["mlr"]).abs() < 0.5,
        "eval {r} vs fit {}",
        held["mlr"]
    );

    // Refit: the same run is not a change; the model is kept byte for byte.
    let old = dir.path().join("mlr.bin");
    let same = dir.path().join("same.bin");
    let v = ok_json(&[
        "refit",
        "--model",
        p(&old),
        "--data",
        RUN,
        "--out",
        p(&same),
        "--json",
    ]);
    assert_eq!(v["changed"], false, "{v}");
    assert_eq!(std::fs::read(&old).unwrap(), std::fs::read(&same).unwrap());
}
