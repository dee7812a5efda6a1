//! `thermcomp fit --model bp|gabp` end to end: the trainer's batched forward
//! pass agrees with the firmware's per-sample path on a whole held-out run,
//! training is reproducible from `--seed`, GA-BP's convergence claim is
//! measured on a synthetic case (and what holds is asserted), and bad sizes fail with one line.

mod common;

use common::{fails_one_line, ok, ok_json, write, FL_THERMAL};
use host_tools::fit::bp::net::predict_rows;
use model_core::Params;
use serde_json::Value;
use std::path::Path;

/// 10 h at 30 s: three temperatures with different time constants and a
/// displacement that is nonlinear in them (a saturating spindle growth, a
/// quadratic term), so a net has something a plane cannot fit.
fn synthetic(dir: &Path) -> String {
    let mut s = String::from("t_s,T1,T2,T3,dz_um,dx_um\n");
    for k in 0..1200 {
        let t = f64::from(k) * 30.0;
        let h = t / 3600.0;
        let t1 = 20.0 + 8.0 * (1.0 - (-h / 1.5).exp()) + 1.5 * (h * 1.1).sin();
        let t2 = 20.0 + 3.0 * (1.0 - (-h / 4.0).exp()) + 0.8 * (h * 0.6).cos();
        let t3 = 21.0 + 0.8 * (h / 2.0).sin();
        let dz = 12.0 * ((t1 - 20.0) / 4.0).tanh() + 0.6 * (t2 - 20.0).powi(2) - 2.0 * (t3 - 21.0);
        let dx = 3.0 * ((t2 - t1) / 3.0).tanh() + 0.5 * (t3 - 21.0);
        s.push_str(&format!("{t},{t1:.4},{t2:.4},{t3:.4},{dz:.4},{dx:.4}\n"));
    }
    write(dir, "synthetic.csv", &s)
}

fn fit(args: &[&str]) -> Value {
    let mut a = vec!["fit"];
    a.extend_from_slice(args);
    a.push("--json");
    ok_json(&a)
}

/// The CSV at `path` as a header and rows of optional numbers.
fn read_csv(path: &str) -> (Vec<String>, Vec<Vec<Option<f64>>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|c| c.trim().parse().ok()).collect())
        .collect();
    (header, rows)
}

#[test]
fn trainer_pass_and_firmware_path_agree_on_every_held_out_row() {
    // A 16-4-2 net on the real run (3 epochs: agreement needs any net, not
    // a good one), written, then run through `thermcomp predict` (decoded
    // blob -> ValidModel -> runner, as the hub does) and through the
    // trainer's batched matrix pass on the same rows.
    let dir = tempfile::tempdir().unwrap();
    let blob = dir.path().join("m.bin");
    let pred = dir.path().join("p.csv");
    let (b, pr) = (blob.to_str().unwrap(), pred.to_str().unwrap());
    fit(&[
        "--data",
        FL_THERMAL,
        "--target",
        "ch1_um,ch5_um",
        "--model",
        "bp",
        "--hidden",
        "4",
        "--epochs",
        "3",
        "--holdout-from-s",
        "86400",
        "--out",
        b,
    ]);
    ok(&["predict", "--model", b, "--data", FL_THERMAL, "--out", pr]);
    let model = model_core::decode(&std::fs::read(&blob).unwrap()).unwrap();
    let Params::Bp(net) = &model.model().params else {
        panic!("not a bp blob")
    };
    let (header, rows) = read_csv(FL_THERMAL);
    let temps: Vec<usize> = (1..=16)
        .map(|i| header.iter().position(|h| *h == format!("T{i}")).unwrap())
        .collect();
    let first: Vec<f64> = temps.iter().map(|&c| rows[0][c].unwrap()).collect();
    let held: Vec<usize> = (0..rows.len())
        .filter(|&r| rows[r][0].unwrap() >= 86400.0)
        .collect();
    let x: Vec<Vec<f64>> = held
        .iter()
        .map(|&r| {
            temps
                .iter()
                .zip(&first)
                .map(|(&c, f)| rows[r][c].unwrap() - f)
                .collect()
        })
        .collect();
    let ours = predict_rows(net, &x).unwrap();
    let (ph, prow) = read_csv(pr);
    let cols: Vec<usize> = ["ch1_um_pred", "ch5_um_pred"]
        .iter()
        .map(|n| ph.iter().position(|h| h == n).unwrap())
        .collect();
    assert_eq!(held.len(), 5355);
    let mut worst = 0.0_f64;
    for (i, &r) in held.iter().enumerate() {
        for (k, &c) in cols.iter().enumerate() {
            let firmware = prow[r][c].expect("a prediction on every held-out row");
            worst = worst.max((firmware - ours[i][k]).abs());
        }
    }
    // 0.01 um: far below the sensors' resolution; the two paths differ only
    // in summation order and in predict's CSV formatting of the values.
    eprintln!("largest difference over {} rows: {worst:e} um", held.len());
    assert!(worst < 0.01, "largest difference {worst} um");
}

#[test]
fn same_seed_same_blob_other_seed_other_blob() {
    let dir = tempfile::tempdir().unwrap();
    let data = synthetic(dir.path());
    let blob = |seed: &str, name: &str| {
        let out = dir.path().join(name);
        fit(&[
            "--data",
            &data,
            "--target",
            "dz_um,dx_um",
            "--model",
            "gabp",
            "--seed",
            seed,
            "--ga-population",
            "12",
            "--ga-generations",
            "5",
            "--ga-hidden",
            "2..6",
            "--epochs",
            "15",
            "--gd-epochs",
            "0",
            "--holdout-from-s",
            "28800",
            "--out",
            out.to_str().unwrap(),
        ]);
        std::fs::read(out).unwrap()
    };
    let (a, b, c) = (blob("3", "a.bin"), blob("3", "b.bin"), blob("4", "c.bin"));
    // Byte-identical although fitness runs on rayon's threads.
    assert_eq!(a, b);
    assert_ne!(a, c);
}

#[test]
fn gabp_starts_lm_from_a_better_point_and_reports_what_it_flashed() {
    let dir = tempfile::tempdir().unwrap();
    let data = synthetic(dir.path());
    let out = dir.path().join("m.bin");
    let v = fit(&[
        "--data",
        &data,
        "--target",
        "dz_um",
        "--model",
        "gabp",
        "--ga-population",
        "20",
        "--ga-generations",
        "10",
        "--ga-hidden",
        "2..8",
        "--gd-epochs",
        "200",
        "--report-convergence",
        "--holdout-from-s",
        "28800",
        "--out",
        out.to_str().unwrap(),
    ]);
    // Seed 000 claims GA-BP reaches the training goal in far fewer epochs
    // (72 versus > 1000). Measured here (docs/fit.md, seeds 1-5), GA-BP's
    // LM epochs to the goal were 7, 1, 5, 4, 3 against 7, 4, 5, 2, 4 for LM
    // from Nguyen-Widrow weights at the GA's hidden size: no consistent win,
    // because LM reaches this goal within a few epochs from any start. What
    // does hold: the GA's start is far better than a random one (here
    // 0.09 vs 0.61 scaled MSE), and both reach the goal within 10 epochs.
    let c = &v["details"]["convergence"]["lm"];
    let start = |who: &str| c[who]["train_mse_start"].as_f64().unwrap();
    let epoch = |who: &str| c[who]["goal_reached_epoch"].as_u64();
    assert_eq!(c["gabp"]["hidden"], c["bp_same_hidden"]["hidden"]);
    assert!(start("gabp") < 0.5 * start("bp_same_hidden"), "{c}");
    for who in ["bp", "bp_same_hidden", "gabp"] {
        assert!(epoch(who).is_some_and(|e| e <= 10), "{who}: {c}");
    }
    // The details' held-out figures for the GA-BP net are computed by the
    // trainer's pass on the dataset's rows; fit scores the decoded blob
    // through the runner. Same rows, same metric code: equal to 1e-9 %.
    let a = v["details"]["holdout"]["gabp"]["dz_um"]["reduction_pct"]
        .as_f64()
        .unwrap();
    let b = v["targets"]["dz_um"]["holdout"]["reduction_pct"]
        .as_f64()
        .unwrap();
    assert!((a - b).abs() < 1e-9, "{a} vs {b}");
}

#[test]
fn sizes_beyond_the_blob_fail_with_one_line_naming_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let data = synthetic(dir.path());
    let out = dir.path().join("m.bin");
    let o = out.to_str().unwrap();
    // 16 inputs x 30 hidden = 480 input weights > MAX_W1 = 384.
    let e = fails_one_line(&[
        "fit", "--data", FL_THERMAL, "--target", "ch1_um", "--model", "bp", "--hidden", "30",
        "--out", o,
    ]);
    assert!(e.contains("MAX_W1") && e.contains("384"), "{e}");
    let e = fails_one_line(&[
        "fit",
        "--data",
        &data,
        "--target",
        "dz_um",
        "--model",
        "gabp",
        "--ga-hidden",
        "8..2",
        "--out",
        o,
    ]);
    assert!(e.contains("--ga-hidden"), "{e}");
    let e = fails_one_line(&[
        "fit",
        "--data",
        &data,
        "--target",
        "dz_um",
        "--model",
        "bp",
        "--ga-mutation",
        "2",
        "--out",
        o,
    ]);
    assert!(e.contains("probability"), "{e}");
}
