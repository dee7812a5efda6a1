//! `thermcomp fit --model auto` end to end on runs of known structure: the
//! input form chosen per target across runs, a lagged heat source found,
//! the CV table and the band reported, and `predict --interval`.

mod common;

use common::{ok, ok_json, p, write};
use serde_json::Value;
use std::path::Path;

/// A first-order lag of `u` with time constant `tau_s` at step `dt_s`,
/// started in steady state (the filter the fbank kind runs).
fn lag(u: &[f64], tau_s: f64, dt_s: f64) -> Vec<f64> {
    let p = (-dt_s / tau_s).exp();
    let mut s = u[0];
    u.iter()
        .map(|&v| {
            s = p * s + (1.0 - p) * v;
            s
        })
        .collect()
}

/// dz_um per row from (T1, T2, speed_rpm).
type Target = dyn Fn(&[f64], &[f64], &[f64]) -> Vec<f64>;

/// One run at 60 s for `hours`: T1 warms with the spindle (speed steps),
/// T2 follows the room, which starts at `room_c`; `target(t1, t2, speed)`
/// gives dz_um per row.
fn run_file(
    dir: &Path,
    name: &str,
    hours: usize,
    room_c: f64,
    speeds: &[f64],
    target: &Target,
) -> String {
    let n = hours * 60;
    let block = n / speeds.len();
    let speed: Vec<f64> = (0..n)
        .map(|k| speeds[(k / block).min(speeds.len() - 1)])
        .collect();
    let heat: Vec<f64> = speed.iter().map(|s| (s / 1000.0).powi(2)).collect();
    let warm = lag(&heat, 1800.0, 60.0);
    let t2: Vec<f64> = (0..n)
        .map(|k| room_c + 0.8 * (k as f64 / 200.0).sin())
        .collect();
    let t1: Vec<f64> = warm.iter().zip(&t2).map(|(w, r)| r + 0.4 * w).collect();
    let y = target(&t1, &t2, &speed);
    let mut s = String::from("t_s,speed_rpm,T1,T2,dz_um\n");
    for k in 0..n {
        s.push_str(&format!(
            "{},{},{:.6},{:.6},{:.6}\n",
            k * 60,
            speed[k],
            t1[k],
            t2[k],
            y[k]
        ));
    }
    write(dir, name, &s)
}

fn fit(args: &[&str]) -> Value {
    let mut a = vec!["fit", "--model", "auto", "--target", "dz_um"];
    a.extend_from_slice(args);
    a.push("--json");
    ok_json(&a)
}

/// `fit --model auto --target dz_um --data DATA --out OUT` plus `extra`,
/// which must fail in one line and write no blob; returns the line.
fn fit_fails(data: &str, out: &Path, extra: &[&str]) -> String {
    let mut a = vec![
        "fit", "--model", "auto", "--target", "dz_um", "--data", data,
    ];
    a.extend(["--out", p(out)]);
    a.extend_from_slice(extra);
    let e = common::fails_one_line(&a);
    assert!(!out.exists(), "no blob written: {e}");
    e
}

/// `fit --model kind --target dz_um` on `data` fails in one line, and
/// writes nothing at `out`; the line.
fn kind_fails(kind: &str, data: &str, out: &Path) -> String {
    let e = common::fails_one_line(&[
        "fit",
        "--model",
        kind,
        "--target",
        "dz_um",
        "--data",
        data,
        "--out",
        p(out),
    ]);
    assert!(!out.exists(), "no blob written: {e}");
    e
}

fn chosen_forms(v: &Value) -> Vec<String> {
    v["details"]["targets"][0]["forms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .collect()
}

fn holdout_rmse(v: &Value) -> f64 {
    v["targets"]["dz_um"]["holdout"]["rmse_um"]
        .as_f64()
        .unwrap()
}

/// Three 8 h runs (r0..r2.csv) at rooms of 18, 22 and 20 C, the spindle off
/// then at 3000 rpm.
fn three_rooms(dir: &Path, f: &Target) -> Vec<String> {
    three_rooms_at(dir, f, [3000.0; 3])
}

/// [`three_rooms`] with the spindle's speed after the first half `tops`
/// (rpm, one per run).
fn three_rooms_at(dir: &Path, f: &Target, tops: [f64; 3]) -> Vec<String> {
    [18.0, 22.0, 20.0]
        .iter()
        .zip(tops)
        .enumerate()
        .map(|(i, (room, top))| run_file(dir, &format!("r{i}.csv"), 8, *room, &[0.0, top], f))
        .collect()
}

/// Three calibration runs at rooms of 18, 22 and 20 C and one held-out run
/// at `held_room_c`, 8 h each; fits auto (leave one run out) and asserts that
/// every averaged candidate has `form` and the held-out run is predicted
/// within 0.05 um rms (the 6-digit rounding of the files and the ridge
/// penalty's shrinkage).
fn form_across_runs(f: &Target, held_room_c: f64, form: &str) {
    form_across_edited_runs(f, held_room_c, form, [3000.0; 3], &|_| {});
}

/// [`form_across_runs`] with the calibration runs' top speeds `tops` and
/// each calibration file passed through `edit` (its path) before the fit;
/// the fit's JSON.
fn form_across_edited_runs(
    f: &Target,
    held_room_c: f64,
    form: &str,
    tops: [f64; 3],
    edit: &dyn Fn(&str),
) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let runs = three_rooms_at(dir.path(), f, tops);
    for r in &runs {
        edit(r);
    }
    let held = run_file(dir.path(), "v.csv", 8, held_room_c, &[0.0, 3000.0], f);
    let out = dir.path().join("m.bin");
    let mut args = Vec::new();
    for r in &runs {
        args.extend(["--data", r.as_str()]);
    }
    args.extend(["--validate", held.as_str(), "--out", p(&out)]);
    let v = fit(&args);
    assert!(v["details"]["scheme"]
        .as_str()
        .unwrap()
        .starts_with("leave one run out"));
    let forms = chosen_forms(&v);
    assert!(forms.iter().all(|f| f == form), "{forms:?}");
    let r = holdout_rmse(&v);
    assert!(r < 0.05, "held-out rmse {r}");
    v
}

#[test]
fn across_runs_the_form_follows_the_data_absolute_here() {
    // dz = 3 (T2 - 20): the room's absolute temperature, which differs from
    // run to run; a change-form model cannot see the 4 K between runs. The
    // held-out run is 2 K warmer than any calibration run.
    let f = |_: &[f64], t2: &[f64], _: &[f64]| t2.iter().map(|v| 3.0 * (v - 20.0)).collect();
    form_across_runs(&f, 24.0, "absolute");
}

#[test]
fn across_runs_the_form_follows_the_data_change_here() {
    // dz = 5 (T1 - T1(0)): the error starts at zero in every run whatever the
    // room temperature, as on a machine zeroed at each run start.
    let f = |t1: &[f64], _: &[f64], _: &[f64]| t1.iter().map(|v| 5.0 * (v - t1[0])).collect();
    form_across_runs(&f, 25.0, "change");
}

/// The displacement logger started 2 h after the temperatures in every
/// calibration run (dz blank on rows 1..=120). The hub starts where the
/// inputs do and takes its references there, so the fit must too: on a
/// grid that began with the target, every change would be taken 0.45 K
/// late in T1 (the room's swing over those 2 h), 2.3 um off in dz, and the
/// held-out run (logged whole) would show it.
#[test]
fn a_target_that_starts_late_is_fitted_from_where_the_inputs_start() {
    let f = |t1: &[f64], _: &[f64], _: &[f64]| t1.iter().map(|v| 5.0 * (v - t1[0])).collect();
    let blank_two_hours = |path: &str| {
        let text = std::fs::read_to_string(path).unwrap();
        let late: Vec<String> = text
            .lines()
            .enumerate()
            .map(|(i, line)| match line.rsplit_once(',') {
                Some((head, _)) if (1..=120).contains(&i) => format!("{head},"),
                _ => line.to_string(),
            })
            .collect();
        std::fs::write(path, late.join("\n") + "\n").unwrap();
    };
    // 0.05 um rms (`form_across_runs`) is far under the 2.3 um of a late
    // reference (1.9 um measured with the grid starting at the target).
    // The runs' top speeds differ (2000, 4000, 3000 rpm), so the run at
    // 4000 leaves the others' envelope and the CV weighs arx and tf (alike
    // runs would leave them out: `Sight`).
    let tops = [2000.0, 4000.0, 3000.0];
    let v = form_across_edited_runs(&f, 25.0, "change", tops, &blank_two_hours);
    assert_eq!(v["details"]["sight"]["static_only"], false);
    // The other families are scored from the same start (2.26 um when
    // their blobs were stepped from the grid's start): arx on T1's change
    // is exact here (1.4e-6 um measured), asserted at 0.05 um as above; tf,
    // fitted for simulation, also gives the speed a gain, which the run at
    // 4000 rpm extrapolates (0.126 um measured), asserted at 0.3 um, under
    // a seventh of a late start's error.
    let rows = family_rows(&v);
    for (family, within) in [("arx", 0.05), ("tf", 0.3)] {
        let row = rows.iter().find(|r| r.0 == family && r.1 == "change");
        let cv = row.and_then(|r| r.2).unwrap_or(f64::NAN);
        assert!(cv < within, "{family}: {rows:?}");
    }
}

#[test]
fn alike_runs_leave_the_band_growth_unmeasured_and_fit_says_so() {
    // Three runs with the same speed programme: leave-one-run-out never
    // takes a fold outside the others' input envelope (in change form every
    // run warms the same way), so the growth stays at its floor and is said
    // to be a guess; a single run whose later blocks run faster than any
    // before them measures it and says nothing.
    let dir = tempfile::tempdir().unwrap();
    let f = |t1: &[f64], _: &[f64], _: &[f64]| t1.iter().map(|v| 5.0 * (v - t1[0])).collect();
    let mut args = vec!["fit", "--model", "auto", "--target", "dz_um"];
    let runs = three_rooms(dir.path(), &f);
    for r in &runs {
        args.extend(["--data", r.as_str()]);
    }
    let out = dir.path().join("m.bin");
    args.extend(["--out", p(&out), "--auto-families", "ridge"]);
    let (_, err) = ok(&args);
    assert!(
        err.contains("note: dz_um: no cross-validation fold left the other folds' input envelope"),
        "{err}"
    );
    let mut json = args.clone();
    json.push("--json");
    let alike = ok_json(&json);
    let band = &alike["details"]["targets"][0]["band"];
    assert_eq!(band["extrapolating_samples"], 0);
    assert_eq!(band["growth"], 1.0);
    // Nor does any of the inputs leave the others' envelope as they move:
    // temperatures enter unfiltered (`Sight`).
    let sight = &alike["details"]["sight"];
    assert_eq!(sight["outside_samples"], 0, "{sight}");
    assert_eq!(sight["static_only"], true, "{sight}");

    let v = lagged_squared_speed(dir.path(), &["--auto-families", "ridge"]);
    // Its forward-chained blocks leave the envelope: filters stay candidates.
    let sight = &v["details"]["sight"];
    assert_eq!(sight["static_only"], false, "{sight}");
    assert!(sight["outside_samples"].as_u64().unwrap() >= 20, "{sight}");
    let band = &v["details"]["targets"][0]["band"];
    // The floor of measured growth is 20 extrapolating CV samples.
    assert!(
        band["extrapolating_samples"].as_u64().unwrap() >= 20,
        "{band}"
    );
    let data = dir.path().join("r.csv");
    let (_, err) = ok(&[
        "fit",
        "--model",
        "auto",
        "--target",
        "dz_um",
        "--data",
        p(&data),
        "--holdout-from-s",
        "57600",
        "--out",
        p(&out),
        "--auto-families",
        "ridge",
    ]);
    assert!(!err.contains("not measured"), "{err}");
}

/// One 24 h run whose dz = 2 * lag(n^2 / 1e6, 2700 s): exactly a
/// heat-source feature of the bank. Calibrate at 2000/4000 rpm (16 h), hold
/// out 6000 rpm (beyond the calibration range, where a linear-in-speed
/// model would fall short); `extra` goes to `fit`.
fn lagged_squared_speed(dir: &Path, extra: &[&str]) -> Value {
    let f = |_: &[f64], _: &[f64], s: &[f64]| {
        let h: Vec<f64> = s.iter().map(|v| (v / 1000.0).powi(2)).collect();
        lag(&h, 2700.0, 60.0).iter().map(|v| 2.0 * v).collect()
    };
    let data = run_file(
        dir,
        "r.csv",
        24,
        20.0,
        &[2000.0, 0.0, 4000.0, 0.0, 6000.0, 0.0],
        &f,
    );
    let out = dir.join("m.bin");
    let mut args = vec![
        "--data",
        &data,
        "--holdout-from-s",
        "57600",
        "--out",
        p(&out),
    ];
    args.extend_from_slice(extra);
    fit(&args)
}

#[test]
fn a_lagged_squared_speed_is_found_and_extrapolates() {
    let dir = tempfile::tempdir().unwrap();
    let v = lagged_squared_speed(dir.path(), &["--auto-families", "ridge"]);
    assert!(v["details"]["scheme"]
        .as_str()
        .unwrap()
        .contains("contiguous blocks"));
    // The table lists every candidate, best first, and marks the averaged ones.
    let table = v["details"]["targets"][0]["cv_table"].as_array().unwrap();
    assert!(table.len() >= 20, "{} candidates", table.len());
    // Best first by the ranking criterion, and the best is averaged.
    let cv: Vec<f64> = table
        .iter()
        .map(|r| r["cv_geo_rmse"].as_f64().unwrap())
        .collect();
    assert!(cv.windows(2).all(|w| w[0] <= w[1]), "sorted best first");
    assert_eq!(table[0]["chosen"], Value::Bool(true));
    let chosen = table
        .iter()
        .filter(|r| r["chosen"] == Value::Bool(true))
        .count();
    // The default averages up to 20, all of the best candidate's form.
    assert!((1..=20).contains(&chosen), "{chosen} chosen");
    let best_form = &table[0]["form"];
    assert!(table
        .iter()
        .filter(|r| r["chosen"] == Value::Bool(true))
        .all(|r| &r["form"] == best_form));
    // Held-out reduction: the peak is 72 um at 6000 rpm; 98 % leaves under
    // 2 % of the mean error, room for the other filters the average carries.
    let red = v["targets"]["dz_um"]["holdout"]["reduction_pct"]
        .as_f64()
        .unwrap();
    assert!(red > 98.0, "held-out reduction {red} %");
}

#[test]
fn predict_interval_brackets_the_prediction_and_widens_outside_the_envelope() {
    let dir = tempfile::tempdir().unwrap();
    let f = |t1: &[f64], _: &[f64], _: &[f64]| t1.iter().map(|v| 4.0 * (v - t1[0])).collect();
    let data = run_file(
        dir.path(),
        "r.csv",
        24,
        20.0,
        &[1000.0, 0.0, 2000.0, 0.0, 6000.0, 0.0],
        &f,
    );
    let model = dir.path().join("m.bin");
    fit(&[
        "--data",
        &data,
        "--holdout-from-s",
        "57600",
        "--out",
        p(&model),
    ]);
    let pred = dir.path().join("p.csv");
    let (_, err) = ok(&[
        "predict",
        "--model",
        p(&model),
        "--data",
        &data,
        "--out",
        p(&pred),
        "--interval",
    ]);
    // The 240 rows at 6000 rpm leave the envelope (speed three times the
    // calibrated), then the cool-down while T1 is still above its
    // calibrated range (measured 299 in all); predict says how many the hub
    // would flag.
    let line = err
        .lines()
        .find(|l| l.contains("lie outside the model's calibration envelope"))
        .unwrap_or_else(|| panic!("no extrapolation note: {err}"));
    let flagged: usize = line
        .split(": ")
        .nth(2)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!((240..=400).contains(&flagged), "{flagged} flagged: {err}");
    let text = std::fs::read_to_string(&pred).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,dz_um_pred,dz_um_lo95,dz_um_hi95"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 24 * 60, "row for row");
    let half = |r: &Vec<f64>| (r[3] - r[2]) / 2.0;
    for r in &rows {
        assert!(r[2] <= r[1] && r[1] <= r[3], "{r:?}");
        // Symmetric band: the prediction in the middle (1e-9 for rounding).
        assert!(((r[2] + r[3]) / 2.0 - r[1]).abs() < 1e-9);
    }
    // Calibration rows sit inside the envelope: the band is the CV half-width
    // there; at 6000 rpm (row 1000 on) T1 leaves it and the band widens.
    let cal = half(&rows[100]);
    let hot = rows[1000..1200].iter().map(half).fold(0.0, f64::max);
    assert!(cal > 0.0);
    assert!(
        hot > cal * 1.5,
        "band {cal} in calibration, {hot} at 6000 rpm"
    );
    // A model without bounds refuses --interval in one line.
    let spec = write(
        dir.path(),
        "lin.toml",
        "kind = \"linear\"\n[[linear]]\noutput = \"dz_um\"\nintercept = 0.0\ncoef = { T1 = 1.0 }\n",
    );
    let lin = dir.path().join("lin.bin");
    ok(&["model", "build", "--spec", &spec, "--out", p(&lin)]);
    let e = common::fails_one_line(&[
        "predict",
        "--model",
        p(&lin),
        "--data",
        &data,
        "--out",
        p(&pred),
        "--interval",
    ]);
    assert!(e.contains("no error band"), "{e}");
}

/// The `cv_table` rows of other families: (family, form, cv_rmse).
fn family_rows(v: &Value) -> Vec<(String, String, Option<f64>)> {
    v["details"]["targets"][0]["cv_table"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["family"] != "ridge")
        .map(|r| {
            let s = |k: &str| r[k].as_str().unwrap().to_string();
            (s("family"), s("form"), r["cv_rmse"].as_f64())
        })
        .collect()
}

#[test]
fn ridge_wins_where_the_filter_bank_is_exact_and_every_family_is_scored() {
    let dir = tempfile::tempdir().unwrap();
    let v = lagged_squared_speed(dir.path(), &[]);
    let fam = &v["details"]["families"];
    assert_eq!(fam["winner"], "ridge");
    assert_eq!(v["model"], "fbank");
    // One row per (family, form) of the default list, each with a finite
    // CV error on the same scored samples.
    let rows = family_rows(&v);
    for f in ["pcr", "arx", "tf", "bp"] {
        for form in ["change", "absolute"] {
            let r = rows
                .iter()
                .find(|r| r.0 == f && r.1 == form)
                .unwrap_or_else(|| panic!("no {f} {form} row: {rows:?}"));
            assert!(r.2.is_some_and(f64::is_finite), "{r:?}");
        }
    }
    assert_eq!(rows.len(), 8);
    // The truth is one feature of the bank; the ridge's CV error is what
    // its penalty's shrinkage costs when the first blocks saw 2000 rpm only
    // and 4000 rpm comes (1.1 um measured), under a third of what a model
    // linear in speed (arx, tf, pcr) or without lag (pcr, bp) reaches
    // (6.3 um at best: a factor 5.7, asserted with room at 3).
    let ridge = v["details"]["targets"][0]["cv_rmse"].as_f64().unwrap();
    let best_other = rows
        .iter()
        .filter_map(|r| r.2)
        .fold(f64::INFINITY, f64::min);
    assert!(
        ridge * 3.0 < best_other,
        "ridge {ridge}, best other {best_other}"
    );
    // Nothing else is chosen: the blob is the averaged ridge.
    let table = v["details"]["targets"][0]["cv_table"].as_array().unwrap();
    assert!(table
        .iter()
        .filter(|r| r["chosen"] == Value::Bool(true))
        .all(|r| r["family"] == "ridge"));
}

#[test]
fn a_pole_far_from_every_bank_filter_is_won_by_a_tf_bank() {
    // dz = 5 lag(T1 - T1(0), 100 h): a first-order response 15 times slower
    // than the bank's slowest filter (6.75 h), exactly an ARX(1, 1, 0) and a
    // first-order TF of T1 in the change form. Over a day it integrates T1's
    // rise, which no sum of faster filters follows into the next block.
    let dir = tempfile::tempdir().unwrap();
    let f = |t1: &[f64], _: &[f64], _: &[f64]| {
        let d: Vec<f64> = t1.iter().map(|v| v - t1[0]).collect();
        lag(&d, 360_000.0, 60.0).iter().map(|v| 5.0 * v).collect()
    };
    let data = run_file(
        dir.path(),
        "r.csv",
        24,
        20.0,
        &[0.0, 3000.0, 0.0, 5000.0, 0.0, 4000.0],
        &f,
    );
    let out = dir.path().join("m.bin");
    let base = [
        "--data",
        &data,
        "--holdout-from-s",
        "57600",
        "--out",
        p(&out),
    ];
    let ridge_only = fit(&[&base[..], &["--auto-families", "ridge"]].concat());
    let v = fit(&base);
    let fam = &v["details"]["families"];
    let winner = fam["winner"].as_str().unwrap();
    assert!(winner == "arx" || winner == "tf", "{fam}");
    assert_eq!(v["model"], "tf", "arx and tf both write a TF bank");
    assert_eq!(v["details"]["targets"][0]["family"], winner);
    // It won beyond noise: its sum of CV mse / variance is lower than the
    // ridge's by more than one standard error of the paired difference
    // (measured: tf 1e-12 against the ridge's 0.109, se 0.030).
    let best = &fam["candidates"][0];
    let (d, se) = (
        best["diff"].as_f64().unwrap(),
        best["se_diff"].as_f64().unwrap(),
    );
    assert!(d < -se, "diff {d}, se {se}");
    // By far: the held-out rmse is under a tenth of the ridge-only model's
    // (measured 4e-7 against 1.25 um: the TF bank is exact up to the files'
    // 6-digit rounding; the ridge misses the slow ramp).
    let (fam_rmse, ridge_rmse) = (holdout_rmse(&v), holdout_rmse(&ridge_only));
    assert!(
        fam_rmse < 0.1 * ridge_rmse,
        "{winner} {fam_rmse} um vs ridge {ridge_rmse} um"
    );
    // The blob carries the family's CV band: --interval is accepted.
    let pred = dir.path().join("p.csv");
    ok(&[
        "predict",
        "--model",
        p(&out),
        "--data",
        &data,
        "--out",
        p(&pred),
        "--interval",
    ]);
}

#[test]
fn an_unknown_family_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let f = |t1: &[f64], _: &[f64], _: &[f64]| t1.iter().map(|v| v - t1[0]).collect();
    let data = run_file(dir.path(), "r.csv", 4, 20.0, &[0.0, 3000.0], &f);
    let out = dir.path().join("m.bin");
    let e = fit_fails(&data, &out, &["--auto-families", "ridge,arx,lstm"]);
    assert!(e.contains("unknown family \"lstm\""), "{e}");
    assert!(!out.exists(), "no blob written");
}

#[test]
fn more_inputs_than_the_hub_reads_are_refused_before_the_search() {
    // 33 temperatures: no model could read them all, so auto says so at
    // once (it used to search first and refuse at the end).
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("t_s");
    for i in 1..=33 {
        text.push_str(&format!(",T{i}"));
    }
    text.push_str(",dz_um\n");
    for k in 0..200 {
        text.push_str(&format!("{}", k * 60));
        for i in 1..=33 {
            text.push_str(&format!(",{:.3}", 20.0 + 0.01 * f64::from(k * i % 17)));
        }
        text.push_str(&format!(",{}\n", f64::from(k) * 0.01));
    }
    let data = write(dir.path(), "r.csv", &text);
    let out = dir.path().join("m.bin");
    let e = fit_fails(&data, &out, &[]);
    assert!(
        e.contains("auto: 33 inputs, but the hub reads at most 32"),
        "{e}"
    );
    assert!(!out.exists(), "no blob written");
    // The static kinds say the same, before training (they used to say
    // "too many inputs", or "more than 32 inputs" after training).
    for kind in ["mlr", "pcr", "bp", "gabp"] {
        let e = kind_fails(kind, &data, &out);
        assert_eq!(
            e,
            format!(
                "error: {kind}: 33 inputs, but the hub reads at most 32: name at most 32 \
                 with --inputs (`thermcomp select` ranks the temperatures)\n"
            )
        );
        assert!(!out.exists(), "no blob written");
    }
}

/// One 8 h run at 60 s with 17 temperatures: T1 warms with the spindle
/// (0 then 3000 rpm), T2 follows the room (starting at `room_c`), T3..T17
/// mix them with a deterministic wobble of their own. dx_um = 5 (T1 -
/// T1(0)) starts at zero every run (change form); dz_um = 3 (T2 - 20)
/// follows the room's level (absolute form).
fn seventeen_sensors(dir: &Path, name: &str, room_c: f64) -> String {
    let n = 8 * 60;
    let speed: Vec<f64> = (0..n)
        .map(|k| if k < n / 2 { 0.0 } else { 3000.0 })
        .collect();
    let heat: Vec<f64> = speed.iter().map(|s| (s / 1000.0).powi(2)).collect();
    let warm = lag(&heat, 1800.0, 60.0);
    let mut head = String::from("t_s,speed_rpm");
    for i in 1..=17 {
        head.push_str(&format!(",T{i}"));
    }
    let mut s = head + ",dx_um,dz_um\n";
    let t1 = |k: usize| room_c + 0.8 * (k as f64 / 200.0).sin() + 0.4 * warm[k];
    let t2 = |k: usize| room_c + 0.8 * (k as f64 / 200.0).sin();
    for (k, rpm) in speed.iter().enumerate() {
        let (a, b) = (t1(k), t2(k));
        s.push_str(&format!("{},{rpm}", k * 60));
        s.push_str(&format!(",{a:.6},{b:.6}"));
        for i in 3..=17 {
            let w = i as f64 / 17.0;
            let wobble = 0.05 * ((k * i) as f64 / 37.0).sin();
            s.push_str(&format!(",{:.6}", w * a + (1.0 - w) * b + wobble));
        }
        s.push_str(&format!(
            ",{:.6},{:.6}\n",
            5.0 * (a - t1(0)),
            3.0 * (b - 20.0)
        ));
    }
    write(dir, name, &s)
}

#[test]
fn targets_of_different_forms_share_one_logged_channel_per_sensor_when_both_would_not_fit() {
    // 17 temperatures read in both forms would take 34 channels, two more
    // than the hub's 32: auto writes the change-form target on the logged
    // channels with each sensor's first sample held (layout.rs). It used to
    // refuse the fit ("the model would read 34 inputs").
    let dir = tempfile::tempdir().unwrap();
    let runs: Vec<String> = [18.0, 22.0, 20.0]
        .iter()
        .enumerate()
        .map(|(i, room)| seventeen_sensors(dir.path(), &format!("r{i}.csv"), *room))
        .collect();
    let held = seventeen_sensors(dir.path(), "v.csv", 24.0);
    let fit_to = |targets: &str, out: &Path| -> Value {
        let mut a = vec!["fit", "--model", "auto", "--target", targets];
        for r in &runs {
            a.extend(["--data", r.as_str()]);
        }
        a.extend(["--validate", held.as_str(), "--out", p(out)]);
        a.extend(["--auto-ensemble", "1", "--auto-families", "ridge", "--json"]);
        ok_json(&a)
    };
    let joint = dir.path().join("j.bin");
    let v = fit_to("dx_um,dz_um", &joint);
    let forms: Vec<&str> = v["details"]["targets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["forms"][0].as_str().unwrap())
        .collect();
    assert_eq!(forms, ["change", "absolute"]);
    let (shown, _) = ok(&["model", "show", "--model", p(&joint)]);
    assert!(shown.contains("T17          absolute"), "{shown}");
    assert!(
        !shown.contains("minus its first sample"),
        "no change-form channel: {shown}"
    );
    assert!(
        shown.contains("T1 held at the run's first sample"),
        "{shown}"
    );
    // The same dx_um as the change-form target fitted alone, to rounding
    // (1e-9 um: the rewrite is exact algebra on values near 20 C).
    let alone = dir.path().join("a.bin");
    fit_to("dx_um", &alone);
    let predict = |model: &Path, out: &str| -> Vec<f64> {
        let path = dir.path().join(out);
        ok(&[
            "predict",
            "--model",
            p(model),
            "--data",
            &held,
            "--out",
            p(&path),
        ]);
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        let col = lines
            .next()
            .unwrap()
            .split(',')
            .position(|c| c == "dx_um_pred")
            .unwrap();
        lines
            .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
            .collect()
    };
    let (a, b) = (predict(&joint, "pj.csv"), predict(&alone, "pa.csv"));
    assert_eq!(a.len(), 8 * 60);
    let worst = a
        .iter()
        .zip(&b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "joint and alone differ by {worst} um");
    // Both targets predict the held-out run, 4 K warmer than any calibration
    // run, within 0.1 um rms (the 6-digit rounding, the penalty's shrinkage).
    for t in ["dx_um", "dz_um"] {
        let r = v["targets"][t]["holdout"]["rmse_um"].as_f64().unwrap();
        assert!(r < 0.1, "{t}: held-out rmse {r}");
    }
}

/// A target that never moves over the calibration rows is refused by every
/// kind before training, naming it (mlr used to report fit 100 % and auto
/// 0 % on the same flat column: both 0/0).
#[test]
fn a_flat_target_is_refused_before_training() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("t_s,T1,T2,dz_um\n");
    for k in 0..200 {
        let t1 = 20.0 + 0.01 * f64::from(k);
        text.push_str(&format!(
            "{},{t1},{},2.5\n",
            k * 60,
            20.0 + 0.1 * f64::from(k % 7)
        ));
    }
    let data = write(dir.path(), "flat.csv", &text);
    let out = dir.path().join("m.bin");
    for kind in ["auto", "mlr", "pcr", "arx", "bp"] {
        let e = kind_fails(kind, &data, &out);
        assert_eq!(
            e,
            "error: dz_um is constant (2.5) on every calibration row: nothing to fit (check \
             the column and --holdout-from-s)\n",
            "{kind}"
        );
        assert!(!out.exists(), "no blob written");
    }
}

/// One 8 h run at 60 s: T1 warms with the spindle (off, then 3000 rpm);
/// T2 is a room sensor logging `room(k)` plus 0.02 K of white noise (its
/// own stream, `seed`); dz = 5 (T1 - T1(0)) + 2 (room - room(0)) and
/// does not see T2's noise.
fn quiet_room_run(dir: &Path, name: &str, room: &dyn Fn(usize) -> f64, seed: u64) -> String {
    let n = 8 * 60;
    let heat: Vec<f64> = (0..n).map(|k| if k < n / 4 { 0.0 } else { 9.0 }).collect();
    let warm = lag(&heat, 1800.0, 60.0);
    let noise = common::white(n, 0.02, seed);
    let mut s = String::from("t_s,speed_rpm,T1,T2,dz_um\n");
    for k in 0..n {
        let t1 = room(k) + 0.4 * warm[k];
        let dz = 5.0 * 0.4 * (warm[k] - warm[0]) + 2.0 * (room(k) - room(0));
        let rpm = if heat[k] > 0.0 { 3000.0 } else { 0.0 };
        let t2 = room(k) + noise[k];
        s.push_str(&format!("{},{rpm},{t1:.6},{t2:.6},{dz:.6}\n", k * 60));
    }
    write(dir, name, &s)
}

/// A room sensor that held its level within its noise in every calibration
/// run (three runs at constant rooms of 18, 22 and 20 C) carries no weight
/// that could be calibrated: auto leaves it out, says so (stderr and the
/// report page), reports its swing
/// and noise (both the 0.02 K of noise, within 15 %: the median's spread
/// over 1440 samples), and its model does not read it, so a held-out run
/// whose room swings 2 K moves no offset through that sensor (on the
/// twin's room protocol such weights cost 31-58 um, docs/fit.md). `mlr`
/// reads it and says so. With no input left that moved, auto refuses the
/// fit in one line.
#[test]
fn an_input_that_did_not_move_in_calibration_is_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let runs: Vec<String> = [18.0, 22.0, 20.0]
        .iter()
        .enumerate()
        .map(|(i, &c)| quiet_room_run(dir.path(), &format!("c{i}.csv"), &move |_| c, 11 + i as u64))
        .collect();
    let swing = |k: usize| 20.0 + 2.0 * (k as f64 / 480.0);
    let held = quiet_room_run(dir.path(), "room.csv", &swing, 99);
    let out = dir.path().join("m.bin");
    let mut args = vec!["fit", "--model", "auto", "--target", "dz_um"];
    for r in &runs {
        args.extend(["--data", r.as_str()]);
    }
    args.extend([
        "--validate",
        held.as_str(),
        "--out",
        p(&out),
        "--auto-families",
        "ridge",
    ]);
    let (_, err) = ok(&args);
    assert!(
        err.contains("note: auto left out T2 swing 0.02") && err.contains("no more than 3 times"),
        "{err}"
    );
    let mut json = args.clone();
    json.push("--json");
    let v = ok_json(&json);
    let page = dir.path().join("page");
    let mut report = args.clone();
    report.extend(["--report", p(&page)]);
    ok(&report);
    let html = std::fs::read_to_string(page.join("index.html")).unwrap();
    assert!(html.contains("<p>auto left out T2 swing 0.02"), "page");
    assert!(
        html.contains("no weight on it can be calibrated.</p>"),
        "page"
    );
    let quiet = v["details"]["quiet_inputs"].as_array().unwrap();
    assert_eq!(quiet.len(), 1, "{quiet:?}");
    assert_eq!(quiet[0]["input"], "T2");
    for key in ["swing", "noise"] {
        let x = quiet[0][key].as_f64().unwrap();
        assert!((0.017..0.023).contains(&x), "{key} {x}");
    }
    let show = ok_json(&["model", "show", "--model", p(&out), "--json"]);
    let inputs: Vec<&str> = show["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["name"].as_str().unwrap())
        .collect();
    assert_eq!(inputs, ["speed_rpm", "T1"]);
    // fit's JSON names the inputs it was given, T2 among them.
    let given = v["inputs"].as_array().unwrap();
    assert!(given.contains(&serde_json::json!("T2")), "{given:?}");
    // T1 is the room plus the spindle's warming, so a model on it (and the
    // speed) takes 5 um/K of the room's 2 K ramp where the machine moves
    // 2 um/K: 3 um/K x 2 K, rms 6/sqrt 3 = 3.46 um, and nothing from T2
    // (3.457 measured; 3.6 leaves room for the penalty's shrinkage).
    let held_rmse = |v: &Value| {
        v["targets"]["dz_um"]["holdout"]["rmse_um"]
            .as_f64()
            .unwrap()
    };
    let auto = held_rmse(&v);
    assert!(auto < 3.6, "auto on the room swing: {auto} um");

    // A kind that reads what it is given fits T2 anyway, and says so.
    let mlr = dir.path().join("mlr.bin");
    let (_, err) = ok(&[
        "fit",
        "--model",
        "mlr",
        "--target",
        "dz_um",
        "--data",
        &runs[0],
        "--out",
        p(&mlr),
    ]);
    let note = err.lines().find(|l| l.starts_with("note: T2 swing 0.02"));
    assert!(
        note.is_some_and(|l| l.contains("the weights on them are fitted to noise")),
        "{err}"
    );
    let none = dir.path().join("none.bin");
    let e = fit_fails(runs[0].as_str(), &none, &["--inputs", "T2"]);
    assert!(
        e.starts_with("error: auto: no input moved beyond 3 times its noise in the calibration rows (T2 swing"),
        "{e}"
    );
}

/// `thermcomp simulate` of 8 h at 40 s into `dir/name.csv` (`extra`: its
/// options), every `*_um` column zeroed at the run's first row (as issue
/// 12's lathe logs them); the path.
fn simulated_zeroed(dir: &Path, name: &str, extra: &[&str]) -> String {
    let path = dir.join(format!("{name}.csv"));
    let mut args = vec![
        "simulate",
        "--out",
        p(&path),
        "--hours",
        "8",
        "--dt-s",
        "40",
    ];
    args.extend_from_slice(extra);
    ok(&args);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    let mut out = head.join(",") + "\n";
    for r in &rows {
        let cells: Vec<String> = r
            .iter()
            .zip(&head)
            .enumerate()
            .map(|(j, (v, h))| {
                let v = if h.ends_with("_um") {
                    v - rows[0][j]
                } else {
                    *v
                };
                format!("{v}")
            })
            .collect();
        out.push_str(&(cells.join(",") + "\n"));
    }
    write(dir, &format!("{name}.csv"), &out)
}

/// Issue 12's lathe protocol on the thermal twin (`scripts/auto_room_split.py
/// --seed 6 --rooms A,B,C`): calibrated on three runs at constant rooms of
/// `rooms` C (steps, spectrum, steps), scored on two runs whose room moves
/// (the `ambient` effect), on the ten temperatures, the default families
/// but bp (the slowest, and static like pcr). The fit's JSON and stderr,
/// and the scored runs' `eval --json`.
fn room_protocol(rooms: [u32; 3]) -> (Value, String, Value) {
    let dir = tempfile::tempdir().unwrap();
    let (machine, _) = ok(&["simulate", "--print-machine"]);
    let mut cal = Vec::new();
    for (i, (room, profile)) in rooms.iter().zip(["steps", "spectrum", "steps"]).enumerate() {
        let toml = machine
            .replace("ambient_c = 20.0", &format!("ambient_c = {room}.0"))
            .replace("coolant_c = 20.0", &format!("coolant_c = {room}.0"));
        let m = write(dir.path(), &format!("m{i}.toml"), &toml);
        let seed = (61 + i).to_string();
        cal.push(simulated_zeroed(
            dir.path(),
            &format!("cal{i}"),
            &[
                "--profile",
                profile,
                "--seed",
                &seed,
                "--effects",
                "",
                "--machine",
                &m,
            ],
        ));
    }
    let room: Vec<String> = [("steps", "64"), ("spectrum", "65")]
        .iter()
        .map(|(profile, seed)| {
            let name = format!("room{seed}");
            simulated_zeroed(
                dir.path(),
                &name,
                &["--profile", profile, "--seed", seed, "--effects", "ambient"],
            )
        })
        .collect();
    let temps = (1..=10)
        .map(|i| format!("T{i}"))
        .collect::<Vec<_>>()
        .join(",");
    let out = dir.path().join("m.bin");
    let mut args = vec!["fit", "--model", "auto", "--target", "dx_um,dy_um,dz_um"];
    for c in &cal {
        args.extend(["--data", c.as_str()]);
    }
    let families = ["--auto-families", "ridge,pcr,arx,tf", "--json"];
    args.extend(["--inputs", &temps, "--out", p(&out)]);
    args.extend(families);
    let (so, err) = ok(&args);
    let mut eval = vec!["eval", "--model", p(&out), "--json"];
    for r in &room {
        eval.extend(["--data", r.as_str()]);
    }
    (serde_json::from_str(&so).unwrap(), err, ok_json(&eval))
}

/// Every CV row of every target: (family, form, temperature filters).
fn cv_rows(v: &Value) -> Vec<(String, String, Value)> {
    v["details"]["targets"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|t| t["cv_table"].as_array().unwrap().iter())
        .map(|r| {
            let s = |k: &str| r[k].as_str().unwrap().to_string();
            (s("family"), s("form"), r["temp_taus_s"].clone())
        })
        .collect()
}

/// The room protocol at rooms of 18, 20 and 23 C, where `auto` used to fail
/// worst (seed 6). The calibration runs are alike, so the CV sees no
/// extrapolation: temperatures enter unfiltered and arx and tf are not
/// tried (`sight.static_only`, said on stderr); T7 and T8, which only the
/// room moves, held within their noise and are left out. The runs start
/// at three levels, so both input forms are weighed. Scored: dx within 10
/// um and dz within 5 um (the lathe's criterion; measured 0.96 and 1.97
/// um, as the script's seed 6 to 0.01 um without bp, where the filter bank
/// and the noise-fitted weights gave 55.6 and 11.2 um); dy, which the
/// criterion does not cover, within 5 um as a guard against the wild
/// extrapolation it had (57.9 um, against a dy of 1.2 um rms; measured
/// 3.12).
#[test]
fn calibrated_at_constant_rooms_auto_holds_when_the_room_moves() {
    let (v, err, e) = room_protocol([18, 20, 23]);
    assert!(
        err.contains("note: auto: cross-validation samples outside the other folds' input envelope: 0, fewer than 20"),
        "{err}"
    );
    let sight = &v["details"]["sight"];
    assert_eq!(sight["static_only"], true, "{sight}");
    assert_eq!(sight["change_only"], false, "{sight}");
    // Starts 2-5 K apart over runs that move about 3 K (measured 1.30):
    // well above 0.5.
    assert!(sight["level_spread"].as_f64().unwrap() > 1.0, "{sight}");
    let rows = cv_rows(&v);
    for (family, _, taus) in &rows {
        assert!(family == "ridge" || family == "pcr", "{family}");
        assert_eq!(*taus, serde_json::json!([]));
    }
    assert!(rows.iter().any(|(_, form, _)| form == "absolute"));
    let quiet: Vec<&str> = v["details"]["quiet_inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|q| q["input"].as_str().unwrap())
        .collect();
    assert_eq!(quiet, ["T7", "T8"]);
    assert_eq!(sight["unexcited"], serde_json::json!(["T7", "T8"]));
    for (t, bound) in [("dx_um", 10.0), ("dy_um", 5.0), ("dz_um", 5.0)] {
        let rmse = e[t]["rmse_um"].as_f64().unwrap();
        assert!(rmse < bound, "{t}: {rmse} um on the room runs");
    }
}

/// The room protocol with every calibration room at 20 C: the runs start at
/// one level (the twin starts each run at its room) and every target is
/// zeroed, so leaving a run out never tests how the absolute form weighs
/// another day's level: only the change form is searched
/// (`sight.change_only`, said on stderr). Scored within the lathe's
/// criterion as above (measured dx 1.91, dy 3.12, dz 1.97 um). On this seed
/// the CV chose changes with both forms as well; where it did not, on
/// seeds 1, 4 and 6 of the lathe plant's variant a, dx was 13.2, 11.8 and
/// 8.9 um with both forms against 0.5, 1.3 and 1.7 with changes only
/// (scripts/auto_lathe_split.py, docs/fit.md "When the room moves").
#[test]
fn calibrated_at_one_room_level_auto_keeps_to_changes() {
    let (v, err, e) = room_protocol([20, 20, 20]);
    assert!(
        err.contains("note: auto: the calibration runs start at one level"),
        "{err}"
    );
    let sight = &v["details"]["sight"];
    assert_eq!(sight["change_only"], true, "{sight}");
    // Every run starts at the same room: the spread is sensor noise
    // (0.02 K) over runs that move about 3 K (measured 0.009).
    assert!(sight["level_spread"].as_f64().unwrap() < 0.05, "{sight}");
    let rows = cv_rows(&v);
    assert!(rows.iter().all(|(_, form, _)| form == "change"), "{rows:?}");
    for (t, bound) in [("dx_um", 10.0), ("dy_um", 5.0), ("dz_um", 5.0)] {
        let rmse = e[t]["rmse_um"].as_f64().unwrap();
        assert!(rmse < bound, "{t}: {rmse} um on the room runs");
    }
}
