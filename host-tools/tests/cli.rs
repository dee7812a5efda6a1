//! `thermcomp` end to end, as a user runs it: exit codes, stdout/stderr
//! discipline, one-line errors, the contract's JSON keys, several runs,
//! irregular sampling.

mod common;

use common::{fails_one_line as fails, ok, ok_json, p};
use std::path::{Path, PathBuf};

const SP2_AMB: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../examples/seed004_sp2_ambient.toml"
);

/// A spindle-like run: T1 steps up by 5 K after 10 min, ambient drifts 1 K
/// over the run; dz_um is what the SP2 + ambient model itself predicts plus a
/// small bias, so the metrics are known in shape.
fn write_run(dir: &Path, name: &str, times: &[f64]) -> PathBuf {
    let path = dir.join(name);
    let mut s = String::from("t_s,T1,ambient_c,dz_um,extra\n");
    for t in times {
        let t1 = if *t >= 600.0 { 25.0 } else { 20.0 };
        let amb = 20.0 + t / 7200.0;
        s.push_str(&format!("{t},{t1},{amb},{},x\n", 0.1 * t / 7200.0));
    }
    std::fs::write(&path, s).unwrap();
    path
}

#[test]
fn build_show_predict_eval_seed004() {
    let dir = tempfile::tempdir().unwrap();
    let blob = dir.path().join("sp2.bin");
    let (so, se) = ok(&["model", "build", "--spec", SP2_AMB, "--out", p(&blob)]);
    assert!(so.is_empty() && se.contains("wrote"), "{so} {se}");

    let (text, _) = ok(&["model", "show", "--model", p(&blob)]);
    assert!(text.contains("kind tf"), "{text}");
    assert!(
        text.contains("cancelled"),
        "ambient's pole/zero at 1: {text}"
    );
    let v = ok_json(&["model", "show", "--model", p(&blob), "--json"]);
    assert_eq!(v["kind"], "tf");
    assert_eq!(v["format_version"], 3);
    assert_eq!(v["outputs"][0], "dz_um");
    assert_eq!(v["inputs"][1]["reference"], "first");
    // SP2's gain (16.0005 - 15.9975) / (1 - 0.99983) to f64 rounding.
    let gain = v["coefficients"][0]["steady_state_gain"].as_f64().unwrap();
    assert!((gain - 0.003 / 0.00017).abs() < 1e-9, "{gain}");

    let times: Vec<f64> = (0..7200).map(f64::from).collect();
    let run = write_run(dir.path(), "run.csv", &times);
    let pred = dir.path().join("pred.csv");
    ok(&[
        "predict",
        "--model",
        p(&blob),
        "--data",
        p(&run),
        "--out",
        p(&pred),
    ]);
    let text = std::fs::read_to_string(&pred).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t_s,dz_um_pred"));
    assert_eq!(lines.clone().count(), 7200, "row for row");
    let first: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(first, ["0", "0"], "no change yet, no displacement");

    let v = ok_json(&["eval", "--model", p(&blob), "--data", p(&run), "--json"]);
    let m = &v["dz_um"];
    for key in [
        "n",
        "rmse_um",
        "fit_pct",
        "r2",
        "eta_pct",
        "max_abs_um",
        "mean_abs_um",
        "dpk_um",
        "reduction_pct",
    ] {
        assert!(m[key].is_number(), "{key} missing: {m}");
    }
    assert_eq!(m["n"], 7200);
    assert_eq!(v.as_object().unwrap().len(), 1, "keyed by target only");
}

/// A filter bank with bounds, as README.md's "Model specs" writes one.
const FBANK_SPEC: &str = r#"
kind = "fbank"
dt_s = 1.0

[fbank]
inputs = [{ name = "T1" }, { name = "ambient_c", reference = 20.0 }]
features = [
  { input = "T1" },
  { input = "T1", tau_s = 600.0 },
  { input = "ambient_c", power = 2 },
]

[[fbank.output]]
output = "dz_um"
intercept = 0.5
coef = [1.0, 2.0, 0.25]

[bounds]
envelope = { T1 = [0.0, 6.0], ambient_c = [-1.0, 2.0] }
half_width = { dz_um = 0.8 }
"#;

/// spec -> blob -> show (text and JSON) -> predict for the fbank kind.
#[test]
fn fbank_spec_builds_shows_and_predicts() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("fb.toml");
    std::fs::write(&spec, FBANK_SPEC).unwrap();
    let blob = dir.path().join("fb.bin");
    ok(&["model", "build", "--spec", p(&spec), "--out", p(&blob)]);

    let (text, _) = ok(&["model", "show", "--model", p(&blob)]);
    for needle in [
        "kind fbank",
        "blob format version 3",
        "s1 = T1 (unfiltered)",
        "s2 = low-pass(T1), tau 10.0000 min, pole 0.99833472",
        "s3 = ambient_c^2 (unfiltered)",
        "dz_um = 0.5 +1 s1 +2 s2 +0.25 s3",
        "T1           calibrated on [0, 6]",
        "dz_um        95 % error band +-0.8",
    ] {
        assert!(text.contains(needle), "{needle:?} not in\n{text}");
    }
    let v = ok_json(&["model", "show", "--model", p(&blob), "--json"]);
    assert_eq!(v["kind"], "fbank");
    assert_eq!(v["format_version"], 3);
    let f = &v["coefficients"]["features"];
    assert_eq!(f[2]["input"], "ambient_c");
    assert_eq!(f[2]["power"], 2);
    // exp(-1 / 600) = 0.9983347214509387 (Python math.exp), to libm rounding.
    let pole = f[1]["pole"].as_f64().unwrap();
    assert!((pole - 0.998_334_721_450_938_7).abs() < 1e-15, "{pole}");
    assert_eq!(v["coefficients"]["outputs"][0]["coef"][2], 0.25);
    assert_eq!(v["bounds"]["envelope"][1]["max"], 2.0);
    assert_eq!(v["bounds"]["half_width"][0]["half_width"], 0.8);

    // First row: T1 20 (its own reference), ambient 20 (= the reference):
    // every feature 0, dz = the intercept.
    let run = write_run(dir.path(), "run.csv", &[0.0, 1.0, 2.0]);
    let pred = dir.path().join("pred.csv");
    ok(&[
        "predict",
        "--model",
        p(&blob),
        "--data",
        p(&run),
        "--out",
        p(&pred),
    ]);
    let text = std::fs::read_to_string(&pred).unwrap();
    let first: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(first, ["0", "0.5"]);
}

#[test]
fn several_runs_restart_the_state_and_are_scored_together_and_apart() {
    let dir = tempfile::tempdir().unwrap();
    let times: Vec<f64> = (0..3600).map(f64::from).collect();
    let a = write_run(dir.path(), "a.csv", &times);
    let b = write_run(dir.path(), "b.csv", &times);
    // The seed 004 model over both runs, then `tail`.
    let both = |command: &str, tail: &[&str]| {
        let mut args = vec![command, "--spec", SP2_AMB, "--data", p(&a), "--data", p(&b)];
        args.extend_from_slice(tail);
        ok(&args).0
    };
    let v: serde_json::Value = serde_json::from_str(&both("eval", &["--json"])).unwrap();
    let m = &v["dz_um"];
    assert_eq!(m["n"], 7200);
    let runs = m["per_run"].as_array().unwrap();
    assert_eq!(runs.len(), 2);
    // Identical runs and a restarted state: identical per-run figures.
    assert_eq!(runs[0]["rmse_um"], runs[1]["rmse_um"]);
    assert_eq!(runs[0]["rmse_um"], m["rmse_um"]);

    let pred = dir.path().join("pred.csv");
    both("predict", &["--out", p(&pred)]);
    let text = std::fs::read_to_string(&pred).unwrap();
    assert!(text.starts_with("run,t_s,dz_um_pred\n"), "{}", &text[..40]);
    assert_eq!(text.lines().count(), 1 + 7200);
}

#[test]
fn irregular_sampling_is_resampled_and_said() {
    let dir = tempfile::tempdir().unwrap();
    let uniform: Vec<f64> = (0..3600).map(f64::from).collect();
    // A logger that drifts and skips: steps of 0.7..1.3 s, some rows missing.
    let mut irregular = Vec::new();
    let mut t = 0.0;
    let mut k = 0u32;
    while t < 3599.0 {
        irregular.push(t);
        k += 1;
        t += if k.is_multiple_of(7) {
            2.6
        } else {
            0.7 + 0.6 * f64::from(k % 3) / 2.0
        };
    }
    let u = write_run(dir.path(), "u.csv", &uniform);
    let i = write_run(dir.path(), "i.csv", &irregular);
    let (ju, _) = ok(&["eval", "--spec", SP2_AMB, "--data", p(&u), "--json"]);
    let (ji, se) = ok(&["eval", "--spec", SP2_AMB, "--data", p(&i), "--json"]);
    assert!(
        se.contains("sampling irregular") && se.contains("resampled"),
        "{se}"
    );
    let (vu, vi): (serde_json::Value, serde_json::Value) = (
        serde_json::from_str(&ju).unwrap(),
        serde_json::from_str(&ji).unwrap(),
    );
    // Same physics, same answer: the 5 K step is sampled at most 1.3 s apart,
    // so linear interpolation moves the TF output by under a percent of the
    // peak (~90 um after an hour): rmse within 0.5 um.
    let (ru, ri) = (
        vu["dz_um"]["rmse_um"].as_f64().unwrap(),
        vi["dz_um"]["rmse_um"].as_f64().unwrap(),
    );
    assert!((ru - ri).abs() < 0.5, "uniform {ru} vs irregular {ri}");
}

#[test]
fn bad_input_gets_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "t_s,T1,ambient_c,dz_um\n0,20,20,0\n1,2O.5,20,0\n").unwrap();
    let se = fails(&["eval", "--spec", SP2_AMB, "--data", p(&bad)]);
    assert!(
        se.contains("bad.csv:3:2 (T1): cannot parse \"2O.5\" as a number"),
        "{se}"
    );
    let (_, se) = ok(&[
        "eval",
        "--spec",
        SP2_AMB,
        "--data",
        p(&bad),
        "--skip-bad-rows",
        "--json",
    ]);
    assert!(se.contains("skipped 1 bad rows"), "{se}");

    let nocol = dir.path().join("nocol.csv");
    std::fs::write(&nocol, "t_s,T1,dz_um\n0,20,0\n1,21,0\n").unwrap();
    let se = fails(&["eval", "--spec", SP2_AMB, "--data", p(&nocol)]);
    assert!(se.contains("needs input \"ambient_c\""), "{se}");

    let spec = dir.path().join("bad.toml");
    std::fs::write(&spec, "kind = \"tf\"\ndt_s = 1.0\n[[tf]]\noutput = \"dz_um\"\ninput = \"T1\"\na = [1.0]\nb = [1.0, -1.0]\n").unwrap();
    let se = fails(&[
        "model",
        "build",
        "--spec",
        p(&spec),
        "--out",
        p(&dir.path().join("x.bin")),
    ]);
    assert!(se.contains("bad.toml:3:1: [[tf]] entry 1: pole 1"), "{se}");

    let garbage = dir.path().join("garbage.bin");
    std::fs::write(&garbage, b"TCMB\x01\x00\x01\x00\xff\xff\xff\xffhello").unwrap();
    let se = fails(&["model", "show", "--model", p(&garbage)]);
    assert!(se.contains("truncated or padded"), "{se}");
    std::fs::write(&garbage, b"PK\x03\x04 not a blob at all").unwrap();
    let se = fails(&["model", "show", "--model", p(&garbage)]);
    assert!(se.contains("bad magic"), "{se}");
    let se = fails(&[
        "model",
        "show",
        "--model",
        p(&dir.path().join("missing.bin")),
    ]);
    assert!(se.contains("cannot read"), "{se}");
}

/// Issue 14: a spec that says the same thing twice is refused where it says
/// it, never resolved silently (README, "Model specs").
#[test]
fn issue14_repeated_spec_entries_are_refused_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.bin");
    let spec = dir.path().join("two.toml");
    std::fs::write(
        &spec,
        "kind = \"linear\"\n\n[[linear]]\noutput = \"x_um\"\nintercept = 0.0\ncoef = { T1 = 1.0 }\n\n\
         [[linear]]\noutput = \"x_um\"\nintercept = 0.0\ncoef = { T2 = 1.0 }\n",
    )
    .unwrap();
    let se = fails(&["model", "build", "--spec", p(&spec), "--out", p(&out)]);
    assert!(
        se.contains("two.toml:8:1: [[linear]] x_um: the output already has an entry"),
        "{se}"
    );
    std::fs::write(
        &spec,
        "kind = \"pcr\"\n[[pcr]]\noutput = \"k\"\ninputs = [\"T1\", \"T1\"]\n\
         components = [{ intercept = 0.0, weights = [1.0, 2.0] }]\nintercept = 0.0\nbeta = [1.0]\n",
    )
    .unwrap();
    let se = fails(&["model", "build", "--spec", p(&spec), "--out", p(&out)]);
    assert!(
        se.contains("two.toml:2:1: [[pcr]] k: input T1 is listed twice"),
        "{se}"
    );
    assert!(!out.exists());
}

/// Issue 14: absurd values are refused with one line (and the place).
#[test]
fn issue14_absurd_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("m.bin");
    let spec = d.join("dt.toml");
    let tf = "kind = \"tf\"\ndt_s = 1e-300\n[[tf]]\noutput = \"dz_um\"\ninput = \"T1\"\na = [0.5]\nb = [1.0, -0.5]\n";
    std::fs::write(&spec, tf).unwrap();
    let se = fails(&["model", "build", "--spec", p(&spec), "--out", p(&out)]);
    assert!(
        se.contains("dt.toml:2:8: dt_s:") && se.contains("not a sample time"),
        "{se}"
    );
    std::fs::write(&spec, tf.replace("1e-300", "1e300")).unwrap();
    let se = fails(&["model", "build", "--spec", p(&spec), "--out", p(&out)]);
    assert!(se.contains("not a sample time"), "{se}");
    // Each spec mistake is named at its entry, in one line.
    let build = |text: &str| {
        std::fs::write(&spec, text).unwrap();
        fails(&["model", "build", "--spec", p(&spec), "--out", p(&out)])
    };
    let good = tf.replace("1e-300", "1.0");
    let long = "x".repeat(900_000);
    let cases = [
        // TOML reads nan: the entry's line, not just "a coefficient".
        (
            ("a = [0.5]", "a = [nan]"),
            "dt.toml:3:1: [[tf]] dz_um <- T1: a: NaN is not a finite number",
        ),
        // A bad reference word (it was serde's "data did not match any
        // variant of untagged enum RefSpec").
        (
            ("a = [0.5]", "reference = \"last\"\na = [0.5]"),
            "dt.toml:6:13: reference must be \"first\", \"absolute\" or a number",
        ),
        // A name with a control character (it built, and `model show`
        // printed a raw NUL).
        (
            ("dz_um", "dz\\u0000um"),
            "column name \"dz\\0um\" holds a control character: a model's column names must be printable",
        ),
        // A 900,000-byte name, cut in the message (the error was 1.8 MB).
        (("dz_um", long.as_str()), "is longer than 24 bytes"),
        // A coefficient of 1e300 (predict then wrote 300-digit offsets).
        (
            ("a = [0.5]", "a = [1e300]"),
            "dt.toml:3:1: [[tf]] dz_um <- T1: a: 1e300 is beyond 1e12 in magnitude",
        ),
        (("\"tf\"", "\"tx\""), "dt.toml:1:8: kind = \"tx\""),
    ];
    for ((from, to), expected) in cases {
        let se = build(&good.replace(from, to));
        assert!(
            se.contains(expected) && se.len() < 300,
            "{expected}: {}",
            &se[..se.len().min(300)]
        );
    }

    let csv = d.join("sim.csv");
    // `simulate --out sim.csv ARGS`, expected to fail with one line.
    let simulate = |args: &[&str]| {
        let mut all = vec!["simulate", "--out", p(&csv)];
        all.extend_from_slice(args);
        fails(&all)
    };
    let se = simulate(&["--hours", "1", "--dt-s", "1e-300"]);
    assert!(
        se.contains("--dt-s") && se.contains("not a sample time"),
        "{se}"
    );
    // A negative number is a value, judged as one (not "unexpected argument").
    let se = simulate(&["--hours", "-1"]);
    assert!(se.contains("--hours must be finite and > 0"), "{se}");
    // A speed above the machine's top speed is refused, not extrapolated
    // (constant:1e12 heated the bearings some 5e12 times as hard as the top speed).
    for rpm in ["constant:12001", "constant:1e12"] {
        let se = simulate(&["--hours", "1", "--profile", rpm]);
        assert!(
            se.contains("is above the machine's max_rpm 12000") && se.contains("--machine"),
            "{se}"
        );
    }
    assert!(!csv.exists(), "nothing written");

    let (machine, _) = ok(&["simulate", "--print-machine"]);
    let cold = d.join("cold.toml");
    std::fs::write(
        &cold,
        machine.replacen("ambient_c = 20.0", "ambient_c = -300.0", 1),
    )
    .unwrap();
    let se = simulate(&["--hours", "1", "--machine", p(&cold)]);
    let line = machine
        .lines()
        .position(|l| l.starts_with("ambient_c = 20.0"))
        .unwrap()
        + 1;
    assert!(
        se.contains(&format!(
            "cold.toml:{line}:1: boundary.ambient_c must be in -50..=100 C"
        )),
        "{se}"
    );
    // Valid fields each, beyond any machine together: a bearing exponent of
    // 1000 drove T1 to 8.9e79 C in a run nothing could read back; refused
    // at the first row out of range, nothing written. max_rpm = 1e300 ended
    // in a NaN of the probe geometry.
    let hot = d.join("hot.toml");
    for (from, to, said) in [
        (
            "bearing_exponent = 1.6",
            "bearing_exponent = 1000.0",
            "of the twin reaches",
        ),
        (
            "max_rpm = 12000.0",
            "max_rpm = 1e300",
            "max_rpm must be at most",
        ),
        // A tool the hub would refuse, which the run then carried.
        (
            "tool_mm = 100.0",
            "tool_mm = 1500.0",
            "tool_mm must be in 0 ..= 1000 mm",
        ),
    ] {
        assert!(machine.contains(from), "{from}");
        std::fs::write(&hot, machine.replacen(from, to, 1)).unwrap();
        let se = simulate(&["--hours", "2", "--dt-s", "60", "--machine", p(&hot)]);
        assert!(se.contains(said), "{se}");
        assert!(!csv.exists(), "nothing written");
    }
    // A file profile's tool beyond the hub's 1000 mm is refused; a slightly
    // negative power, as a drive's regenerative braking logs, is taken.
    let prof = d.join("prof.csv");
    let profile = format!("file:{}", p(&prof));
    let with = |cells: &str| {
        std::fs::write(
            &prof,
            format!("t_s,speed_rpm,power_kw,tool_mm\n0,{cells}\n60,{cells}\n"),
        )
        .unwrap();
    };
    with("1000,1,1e6");
    let se = simulate(&["--profile", &profile]);
    assert!(
        se.contains("tool_mm 1000000 at t_s = 0 is outside the hub's 0 ..= 1000 mm"),
        "{se}"
    );
    with("1000,-0.2,100");
    ok(&["simulate", "--out", p(&csv), "--profile", &profile]);
    std::fs::remove_file(&csv).unwrap();

    let run = write_run(d, "run.csv", &(0..600).map(f64::from).collect::<Vec<_>>());
    let se = fails(&[
        "fit",
        "--data",
        p(&run),
        "--target",
        "dz_um",
        "--inputs",
        "T1,dz_um",
        "--model",
        "mlr",
        "--out",
        p(&out),
    ]);
    assert!(
        se.contains("dz_um is both a --target and one of the --inputs"),
        "{se}"
    );

    let blob = d.join("sp2.bin");
    ok(&["model", "build", "--spec", SP2_AMB, "--out", p(&blob)]);
    let se = fails(&[
        "replay",
        "--model",
        p(&blob),
        "--data",
        p(&run),
        "--candump",
        p(&d.join("c.log")),
        "--interface",
        "can0\n(0.0) can0 123#00",
    ]);
    assert!(se.contains("--interface") && se.contains("control"), "{se}");
    assert!(!d.join("c.log").exists());

    // One -1e308 cell: refused where it is, not "the target is constant".
    let huge = d.join("huge.csv");
    std::fs::write(
        &huge,
        "t_s,T1,T2,dz_um\n0,20,20,0\n1,21,20,1\n2,22,21,-1e308\n3,23,21,2\n",
    )
    .unwrap();
    let se = fails(&[
        "select",
        "--data",
        p(&huge),
        "--target",
        "dz_um",
        "--method",
        "grey",
        "--json",
    ]);
    assert!(
        se.contains("huge.csv:4:4 (dz_um): value \"-1e308\" is beyond 1e15"),
        "{se}"
    );
}

/// A run file's (quoted) column name with a control character in it: `fit`
/// refuses it in one line, with the name escaped, before fitting (it used
/// to write the blob, and `model show` printed the escape raw), for every
/// kind; an unused such column stays ignored, as any unknown column.
#[test]
fn fit_refuses_a_column_name_with_a_control_character() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = write_run(
        d,
        "r.csv",
        &(0..200).map(|k| 30.0 * f64::from(k)).collect::<Vec<_>>(),
    );
    let text = std::fs::read_to_string(&run).unwrap();
    std::fs::write(&run, text.replacen("T1,", "\"T1\u{1b}[2J\",", 1)).unwrap();
    let out = d.join("m.bin");
    for model in ["mlr", "auto"] {
        let se = fails(&[
            "fit",
            "--data",
            p(&run),
            "--target",
            "dz_um",
            "--model",
            model,
            "--inputs",
            "T1\u{1b}[2J",
            "--out",
            p(&out),
        ]);
        assert!(
            se.contains("column name \"T1\\u{1b}[2J\" holds a control character"),
            "{model}: {se}"
        );
        assert!(!out.exists(), "{model}");
    }
    ok(&[
        "fit",
        "--data",
        p(&run),
        "--target",
        "dz_um",
        "--model",
        "mlr",
        "--inputs",
        "ambient_c",
        "--out",
        p(&out),
    ]);
}

/// Issue 14: clap's usage errors are one line like every other error.
#[test]
fn issue14_usage_errors_are_one_line() {
    let se = fails(&["fit", "--no-such-flag"]);
    assert!(
        se.starts_with("error: unexpected argument '--no-such-flag'"),
        "{se}"
    );
    let se = fails(&["eval", "--json"]);
    assert!(!se.contains(":;"), "{se}");
    assert!(se.contains("required"), "{se}");
    let se = fails(&["nonsense"]);
    assert!(se.contains("unrecognized subcommand"), "{se}");
    let out = common::run(&["fit", "--help"]);
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("--target"));
}

/// Issue 14: rows left out by --skip-bad-rows are counted in the JSON, not
/// only on stderr.
#[test]
fn issue14_skipped_rows_are_in_the_json() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut s = String::from("t_s,T1,T2,ambient_c,dz_um\n");
    for k in 0..400 {
        let t = f64::from(k);
        let cell = if k == 7 || k == 9 {
            "x".to_string()
        } else {
            format!("{}", 20.0 + t / 100.0)
        };
        s.push_str(&format!(
            "{t},{cell},{},{},{}\n",
            20.0 + (t / 37.0).sin(),
            20.0 + t / 400.0,
            0.5 * t / 100.0 + (t / 37.0).sin()
        ));
    }
    let run = d.join("run.csv");
    std::fs::write(&run, s).unwrap();
    let skip = "--skip-bad-rows";
    let v = ok_json(&["eval", "--spec", SP2_AMB, "--data", p(&run), skip, "--json"]);
    assert_eq!(v["dz_um"]["skipped_rows"], 2, "{v}");
    let v = ok_json(&[
        "fit",
        "--data",
        p(&run),
        "--target",
        "dz_um",
        "--inputs",
        "T1,T2",
        "--model",
        "mlr",
        "--out",
        p(&d.join("m.bin")),
        skip,
        "--json",
    ]);
    assert_eq!(v["skipped_rows"], 2, "{v}");
    let v = ok_json(&[
        "select",
        "--data",
        p(&run),
        "--target",
        "dz_um",
        "--inputs",
        "T1,T2",
        "--method",
        "grey",
        skip,
        "--json",
    ]);
    assert_eq!(v["skipped_rows"], 2, "{v}");
}

/// Issue 14: a CR-only file (old Mac line ends) named its bad cell as line 1.
#[test]
fn issue14_cr_only_files_name_the_right_line() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("mac.csv");
    std::fs::write(
        &bad,
        "t_s,T1,ambient_c,dz_um\r0,20,20,0\r1,20,20,0\r2,2O.5,20,0\r",
    )
    .unwrap();
    let se = fails(&["eval", "--spec", SP2_AMB, "--data", p(&bad)]);
    assert!(
        se.contains("mac.csv:4:2 (T1): cannot parse \"2O.5\""),
        "{se}"
    );
}

#[test]
fn predict_keeps_a_skipped_row_as_an_empty_row() {
    // Rows 3 and 5 (0-based) have a bad T1 cell; with --skip-bad-rows the
    // prediction file still has one row per data row, those two empty.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut s = String::from("t_s,T1,dz_um\n");
    for k in 0..8 {
        let cell = if k == 3 || k == 5 {
            "bad".to_string()
        } else {
            format!("{}", 20 + k)
        };
        s.push_str(&format!("{k},{cell},0\n"));
    }
    let run = d.join("run.csv");
    std::fs::write(&run, s).unwrap();
    let spec = d.join("m.toml");
    std::fs::write(
        &spec,
        "kind = \"linear\"\n[[linear]]\noutput = \"dz_um\"\nintercept = 0.0\ncoef = { T1 = 2.0 }\n",
    )
    .unwrap();
    let m = d.join("m.bin");
    ok(&["model", "build", "--spec", p(&spec), "--out", p(&m)]);
    let out = d.join("pred.csv");
    let v = ok_json(&[
        "predict",
        "--model",
        p(&m),
        "--data",
        p(&run),
        "--out",
        p(&out),
        "--skip-bad-rows",
        "--json",
    ]);
    assert_eq!(v["rows"], 8, "{v}");
    assert_eq!(v["skipped_rows"], 2, "{v}");
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1 + 8);
    assert_eq!(lines[1 + 3], ",");
    assert_eq!(lines[1 + 5], ",");
    // The others: dz = 2 T1 exactly.
    assert_eq!(lines[1 + 4], "4,48");
    assert_eq!(lines[1 + 7], "7,54");
}
