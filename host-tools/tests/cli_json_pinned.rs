//! The `--json` objects of `fit` (mlr and auto), `eval`, `select` and
//! `diagnose` pinned byte for byte against outputs captured from the command
//! line before the typed library layer existed (host-tools/tests/data/cli_json/,
//! captured with the release binary of commit 3699374). The library's
//! typed outcomes must serialise to exactly what the CLI printed then.
//!
//! Re-captured on purpose once since (fit_mlr, eval_mlr, fit_auto): blob
//! format 3 adds one byte (`bytes` 118 -> 119, 1296 -> 1297), and `mlr`
//! solves by blocked QR then an SVD of the triangle ("solver" string; its
//! numbers moved within 1e-12 relative, except a calibration residual mean
//! of 2e-14 um, which is rounding around zero). Every other byte, key order
//! and number format included, was as captured. fit_auto once more when
//! `auto` began ranking candidates by the geometric mean of the per-fold
//! errors (a method change: `cv_geo_rmse` added to every CV-table row, one
//! ensemble member and the numbers that follow from it changed; held-out
//! rmse 0.634 -> 0.630 um). diagnose once when looks whose verdict may not
//! decide alone were set to `none` (issue 13, third round: one look's
//! `ambient` -> `none` and the `rule` text; the verdict and every number
//! unchanged), and again when the rule text gained the fifth round's
//! lag-or-heat check, gate 3's two new ways and gate 4's size 0.55 (issue
//! 13; the `rule` text only, every other byte unchanged), and once more when
//! the rule text gained the quiet-cycle chiller gate (gate 5, fourth round)
//! and gate 3's temperature-only way, which it had left out (the `rule`
//! text only). fit_auto once more when its `cv_table` was ordered by
//! `cv_geo_rmse`, the ranking criterion, instead of the pooled `cv_rmse`
//! (the same 50 rows in another order; every other byte, masked keys
//! aside, unchanged), and once more when model-core's filter bank grew to
//! 256 features (`settings.max_features` 128 -> 256, nothing else), and
//! once more when every CV-table row gained `cv_geo_se` (2026-11-28; with
//! that key removed the new capture equals the old, `out` and `seconds`
//! aside), and once more when `details` gained `quiet_inputs` and `sight`
//! (2026-11-28, fit/quiet.rs and `Sight`: none left out and the CV sees
//! extrapolation on this run, so with those two keys removed the new
//! capture equals the old, `out` and `seconds` aside), and once more when
//! `sight` gained `unexcited`, `level_spread` and `change_only`
//! (2026-11-28, fit/auto/sight.rs: one run, so `[]`, `null` and `false`;
//! every other byte as before, `seconds` aside).
//!
//! Every command runs in the repository root with the relative paths the
//! fixtures were captured with (`eval` names each run's file). `fit --model
//! auto` takes about a minute in a debug build, so that case runs the release
//! binary and is `#[ignore]`d in the plain test run; `.ci/run` builds the
//! release binary and runs it with `--ignored`.
//!
//! The `details` of `fit` for pcr, arx, tf, bp, gabp and arma (the
//! `fit_<kind>*.json` fixtures but fit_mlr and fit_auto) were captured with
//! the release binary of commit c138810, the last whose trainers built
//! `details` as `serde_json::Value`: they pin that the typed reports
//! (`fit::Details`) serialise to what the `json!` code printed.
//!
//! Masked before comparing, because they legitimately vary: every key named
//! `seconds` (wall-clock time of an auto candidate, an LM or GA run) or
//! `ga_seconds` (gabp's GA), and `out` (the blob path, a temporary directory
//! here).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root, where the fixtures' commands were run.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The release binary of this tree (`cargo build --release -p host-tools`).
fn release_bin() -> PathBuf {
    let bin = root().join("target/release/thermcomp");
    assert!(
        bin.exists(),
        "{}: build it first (cargo build --release -p host-tools)",
        bin.display()
    );
    bin
}

/// Runs `bin args` in the repository root; asserts success; returns stdout.
fn stdout_of(bin: &Path, args: &[&str]) -> String {
    let out = Command::new(bin)
        .args(args)
        .current_dir(root())
        .output()
        .expect("thermcomp runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "thermcomp {args:?} failed: {stderr}");
    String::from_utf8(out.stdout).unwrap()
}

fn debug_bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_thermcomp"))
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/cli_json")
        .join(name)
}

/// The example run, relative to the repository root as captured.
const SPINDLE: &str = "examples/synthetic_spindle.csv";

/// Replaces the value of every `"seconds":<number>` and `"out":"<text>"` in
/// the raw JSON text with `0` and `""`, leaving every other byte as printed.
fn mask(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    loop {
        let next = [
            ("\"seconds\":", false),
            ("\"ga_seconds\":", false),
            ("\"out\":\"", true),
        ]
        .into_iter()
        .filter_map(|(key, quoted)| rest.find(key).map(|i| (i, key, quoted)))
        .min_by_key(|(i, _, _)| *i);
        let Some((i, key, quoted)) = next else {
            out.push_str(rest);
            return out;
        };
        out.push_str(&rest[..i + key.len()]);
        rest = &rest[i + key.len()..];
        if quoted {
            let end = rest.find('"').expect("closing quote");
            out.push('"');
            rest = &rest[end + 1..];
        } else {
            let end = rest
                .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
                .unwrap_or(rest.len());
            out.push('0');
            rest = &rest[end..];
        }
    }
}

/// Runs `args` and compares its stdout with the captured fixture byte for
/// byte (key order, number formatting, the final newline), masked alike.
fn pinned(bin: &Path, args: &[&str], fixture_name: &str) {
    let stdout = stdout_of(bin, args);
    assert_eq!(stdout.lines().count(), 1, "one JSON line: {stdout}");
    serde_json::from_str::<serde_json::Value>(&stdout).expect("valid JSON");
    let want = std::fs::read_to_string(fixture(fixture_name)).unwrap();
    let (got, want) = (mask(&stdout), mask(&want));
    if got != want {
        let at = got
            .bytes()
            .zip(want.bytes())
            .take_while(|(a, b)| a == b)
            .count();
        let lo = at.saturating_sub(80);
        panic!(
            "{fixture_name}: --json differs from the captured output at byte {at}:\n got: ...{}\nwant: ...{}",
            &got[lo..(at + 80).min(got.len())],
            &want[lo..(at + 80).min(want.len())]
        );
    }
}

#[test]
fn fit_mlr_json_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.bin");
    let data = SPINDLE;
    pinned(
        &debug_bin(),
        &[
            "fit",
            "--data",
            data,
            "--target",
            "dz_um",
            "--inputs",
            "T1,T2,T3,T5,speed_rpm",
            "--model",
            "mlr",
            "--holdout-from-s",
            "43200",
            "--out",
            p(&out),
            "--json",
        ],
        "fit_mlr.json",
    );
}

#[test]
#[ignore = "about a minute in a debug build: runs the release binary (.ci/run: --ignored)"]
fn fit_auto_json_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.bin");
    let data = SPINDLE;
    pinned(
        &release_bin(),
        &[
            "fit",
            "--data",
            data,
            "--target",
            "dz_um",
            "--model",
            "auto",
            "--holdout-from-s",
            "43200",
            "--out",
            p(&out),
            "--json",
        ],
        "fit_auto.json",
    );
}

/// `fit --json` on [`SPINDLE`] (target dz_um, held out from 12 h) with the
/// kind's `args`, against the fixture `fixture_name`.
fn pinned_fit(args: &[&str], fixture_name: &str) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.bin");
    let mut all = vec![
        "fit",
        "--data",
        SPINDLE,
        "--target",
        "dz_um",
        "--holdout-from-s",
        "43200",
    ];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--out", p(&out), "--json"]);
    pinned(&debug_bin(), &all, fixture_name);
}

#[test]
fn fit_pcr_json_is_unchanged() {
    pinned_fit(&["--model", "pcr"], "fit_pcr.json");
}

/// Forward selection and the tail search scheme (`--search-folds 1`).
#[test]
fn fit_arx_json_is_unchanged() {
    pinned_fit(
        &[
            "--model",
            "arx",
            "--inputs",
            "T1,T2,T3,T5,speed_rpm",
            "--select-inputs",
            "forward",
            "--max-inputs",
            "3",
            "--search-folds",
            "1",
        ],
        "fit_arx_forward.json",
    );
}

#[test]
fn fit_tf_json_is_unchanged() {
    pinned_fit(
        &[
            "--model",
            "tf",
            "--inputs",
            "T1,T2,T3",
            "--select-inputs",
            "forward",
            "--max-inputs",
            "2",
            "--lm-iterations",
            "5",
        ],
        "fit_tf_forward.json",
    );
}

/// `--goal 0`: never reached, so no time-to-goal (wall-clock) is printed.
#[test]
fn fit_bp_json_is_unchanged() {
    pinned_fit(
        &[
            "--model",
            "bp",
            "--inputs",
            "T1,T2,T3,T5",
            "--hidden",
            "4",
            "--epochs",
            "20",
            "--goal",
            "0",
        ],
        "fit_bp.json",
    );
}

/// With the convergence comparison (LM and gradient-descent runs).
#[test]
fn fit_gabp_json_is_unchanged() {
    pinned_fit(
        &[
            "--model",
            "gabp",
            "--inputs",
            "T1,T2,T3,T5",
            "--epochs",
            "10",
            "--ga-population",
            "4",
            "--ga-generations",
            "2",
            "--ga-hidden",
            "2..4",
            "--gd-epochs",
            "20",
            "--report-convergence",
            "--goal",
            "0",
        ],
        "fit_gabp_convergence.json",
    );
}

#[test]
fn fit_arma_json_is_unchanged() {
    pinned_fit(
        &["--model", "arma", "--max-p", "2", "--max-q", "2"],
        "fit_arma.json",
    );
}

#[test]
fn eval_json_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.bin");
    let data = SPINDLE;
    stdout_of(
        &debug_bin(),
        &[
            "fit",
            "--data",
            data,
            "--target",
            "dz_um",
            "--inputs",
            "T1,T2,T3,T5,speed_rpm",
            "--model",
            "mlr",
            "--holdout-from-s",
            "43200",
            "--out",
            p(&out),
        ],
    );
    pinned(
        &debug_bin(),
        &["eval", "--model", p(&out), "--data", data, "--json"],
        "eval_mlr.json",
    );
}

#[test]
fn select_maxtree_json_is_unchanged() {
    let data = SPINDLE;
    pinned(
        &debug_bin(),
        &[
            "select", "--data", data, "--target", "dz_um", "--method", "maxtree", "--json",
        ],
        "select_maxtree.json",
    );
}

/// `select --method grey` and `--method wgrey`: captured with the release
/// binary of commit 65798c0, the last before `select` became a typed job
/// (`SelectOutcome`), so they pin that the typed outcomes serialise to what
/// the JSON-building code printed.
#[test]
fn select_grey_json_is_unchanged() {
    pinned(
        &debug_bin(),
        &[
            "select", "--data", SPINDLE, "--target", "dz_um", "--method", "grey", "--json",
        ],
        "select_grey.json",
    );
}

/// See [`select_grey_json_is_unchanged`].
#[test]
fn select_wgrey_json_is_unchanged() {
    pinned(
        &debug_bin(),
        &[
            "select",
            "--data",
            SPINDLE,
            "--target",
            "dx_um,dz_um",
            "--method",
            "wgrey",
            "--top",
            "3",
            "--json",
        ],
        "select_wgrey.json",
    );
}

#[test]
fn diagnose_json_is_unchanged() {
    let (sim, real) = (fixture("sim.csv"), fixture("real.csv"));
    pinned(
        &debug_bin(),
        &["diagnose", "--sim", p(&sim), "--real", p(&real), "--json"],
        "diagnose.json",
    );
}

/// The example run's first 20000 s as a run of its own (header and rows
/// as written), for a model that `refit` then tests on the whole run.
fn early_run(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join(SPINDLE)).unwrap();
    let mut lines = text.lines();
    let mut early = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let t: f64 = line.split(',').next().unwrap().parse().unwrap();
        if t < 20000.0 {
            early.push_str(line);
            early.push('\n');
        }
    }
    let path = dir.join("early.csv");
    std::fs::write(&path, early).unwrap();
    path
}

/// A blob fitted on [`early_run`] with `fit_args` after `--model`.
fn early_model(dir: &Path, fit_args: &[&str]) -> PathBuf {
    let early = early_run(dir);
    let blob = dir.join("old.bin");
    let mut args = vec!["fit", "--data", p(&early), "--out", p(&blob), "--model"];
    args.extend_from_slice(fit_args);
    stdout_of(&debug_bin(), &args);
    blob
}

/// `refit --json` (with `extra` flags) of an early model fitted with
/// `fit_args`, on the whole example run, against `fixture`.
fn refit_pinned(fit_args: &[&str], extra: &[&str], fixture: &str) {
    let dir = tempfile::tempdir().unwrap();
    let old = early_model(dir.path(), fit_args);
    let out = dir.path().join("new.bin");
    let mut args = vec!["refit", "--json"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--model", p(&old), "--data", SPINDLE, "--out", p(&out)]);
    pinned(&debug_bin(), &args, fixture);
}

/// `refit --json` of an early mlr model on the whole example run:
/// changed, updated by RLS, the update kept. Fixtures refit_*.json were
/// captured with the release binary of commit 1bb5791, before refit
/// became a typed job.
#[test]
fn refit_rls_json_is_unchanged() {
    let mlr = ["mlr", "--target", "dz_um,dx_um", "--inputs", "T1,T2,T3"];
    refit_pinned(&mlr, &[], "refit_rls.json");
}

/// See [`refit_rls_json_is_unchanged`]: `--method window`.
#[test]
fn refit_window_json_is_unchanged() {
    let mlr = ["mlr", "--target", "dz_um,dx_um", "--inputs", "T1,T2,T3"];
    refit_pinned(
        &mlr,
        &["--method", "window", "--window-h", "6"],
        "refit_window.json",
    );
}

/// See [`refit_rls_json_is_unchanged`]: a TF bank (least-squares entry gains).
#[test]
fn refit_tf_json_is_unchanged() {
    let tf = [
        "tf", "--target", "dz_um", "--inputs", "T1,T2", "--na", "1", "--nb", "1", "--nk", "0",
    ];
    refit_pinned(&tf, &[], "refit_tf.json");
}
