//! Regressions of issue 14: huge values that hung the SVD, stdout write
//! failures that panicked, outputs that overwrote inputs, and reads without a
//! bound. Every case must end within seconds with its exact outcome.

mod common;

use common::{fails_one_line, p, write};
use std::io::Read;
use std::os::fd::OwnedFd;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const SP2_AMB: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../examples/seed004_sp2_ambient.toml"
);

/// How long a case may take before it counts as a hang.
const DEADLINE: Duration = Duration::from_secs(60);

/// Runs `thermcomp` with `args` and `stdout`, killing it past [`DEADLINE`]
/// (a hang fails the test instead of stalling the suite).
fn run_bounded(args: &[&str], stdout: Stdio) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_thermcomp"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .expect("thermcomp runs");
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = Vec::new();
        let _ = stderr.read_to_end(&mut s);
        s
    });
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > DEADLINE {
            let _ = child.kill();
            let _ = child.wait();
            panic!("thermcomp {args:?} still running after {DEADLINE:?}: hang");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Output {
        status,
        stdout: Vec::new(),
        stderr: reader.join().unwrap(),
    }
}

/// Fails within [`DEADLINE`] with exactly `expected` as its one stderr line.
fn fails_with(args: &[&str], expected: &str) {
    let out = run_bounded(args, Stdio::null());
    let se = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success(), "thermcomp {args:?} should fail");
    assert_eq!(se, format!("{expected}\n"), "thermcomp {args:?}");
}

/// A run of `n` rows: t_s, speed_rpm, T1 (alternating +-1e308 when `huge`),
/// T2, ambient_c, dz_um.
fn run_text(n: usize, huge: bool) -> String {
    let mut s = String::from("t_s,speed_rpm,T1,T2,ambient_c,dz_um\n");
    for k in 0..n {
        let t1 = if huge {
            if k % 2 == 0 {
                "1e308".to_string()
            } else {
                "-1e308".to_string()
            }
        } else {
            format!("{}", 20.0 + (k % 7) as f64 * 0.3)
        };
        let speed = if (k / 50) % 2 == 0 { 3000 } else { 9000 };
        let t2 = 20.0 + (k as f64 * 0.37).sin();
        let dz = 0.5 * (k as f64 * 0.11).cos() + k as f64 * 0.01;
        s.push_str(&format!("{k},{speed},{t1},{t2},20.5,{dz}\n"));
    }
    s
}

/// `text` with each line's cells edited by `f(line index, cells)` (the
/// header is line 0).
fn edited(text: &str, f: impl Fn(usize, &mut Vec<String>)) -> String {
    text.lines()
        .enumerate()
        .map(|(i, line)| {
            let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
            f(i, &mut cells);
            format!("{}\n", cells.join(","))
        })
        .collect()
}

fn blob(dir: &Path) -> String {
    let out = dir.join("sp2.bin");
    common::ok(&["model", "build", "--spec", SP2_AMB, "--out", p(&out)]);
    p(&out).to_string()
}

// ---- 1. huge values: no hang, one line naming the cell ---------------------
// The run-file reader refuses a cell beyond 1e15 in magnitude where it stands
// (file:line:column); behind it, every fit checks that its columns can be
// centred and scaled, and every SVD is capped in iterations.

/// `fit --model kind` on `rows` rows with T1 at +-1e308 fails with the
/// reader's one line naming the first such cell, and writes no blob.
fn huge_fit_is_refused(kind: &str, rows: usize) {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "huge.csv", &run_text(rows, true));
    let out = dir.path().join("m.bin");
    fails_with(
        &[
            "fit",
            "--data",
            &data,
            "--target",
            "dz_um",
            "--inputs",
            "T1,T2",
            "--model",
            kind,
            "--out",
            p(&out),
        ],
        &format!("error: {data}:2:3 (T1): value \"1e308\" is beyond 1e15 in magnitude"),
    );
    assert!(!out.exists());
}

#[test]
fn huge_column_mlr_six_rows_is_refused() {
    huge_fit_is_refused("mlr", 6);
}

#[test]
fn huge_column_bp_is_refused() {
    huge_fit_is_refused("bp", 400);
}

#[test]
fn huge_channel_in_diagnose_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sim = write(dir.path(), "sim.csv", &run_text(400, false));
    let real = write(dir.path(), "real.csv", &run_text(400, true));
    fails_with(
        &["diagnose", "--sim", &sim, "--real", &real, "--json"],
        &format!("error: {real}:2:3 (T1): value \"1e308\" is beyond 1e15 in magnitude"),
    );
}

#[test]
fn huge_column_in_refit_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "huge.csv", &run_text(400, true));
    let b = blob(dir.path());
    let out = dir.path().join("new.bin");
    fails_with(
        &["refit", "--model", &b, "--data", &data, "--out", p(&out)],
        &format!("error: {data}:2:3 (T1): value \"1e308\" is beyond 1e15 in magnitude"),
    );
}

#[test]
fn huge_column_in_select_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = write(dir.path(), "huge.csv", &run_text(400, true));
    for method in ["grey", "wgrey", "maxtree"] {
        fails_with(
            &[
                "select", "--data", &data, "--target", "dz_um", "--inputs", "T1,T2", "--method",
                method, "--json",
            ],
            &format!("error: {data}:2:3 (T1): value \"1e308\" is beyond 1e15 in magnitude"),
        );
    }
}

// ---- 2. stdout write failures: no panic -----------------------------------

/// A pipe whose reader is already closed: every write to it is EPIPE.
fn closed_pipe() -> Stdio {
    let (r, w): (OwnedFd, OwnedFd) = nix::unistd::pipe().unwrap();
    drop(r);
    Stdio::from(w)
}

#[test]
fn closed_stdout_pipe_ends_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let b = blob(dir.path());
    for args in [
        vec!["model", "show", "--model", b.as_str()],
        vec!["model", "show", "--model", b.as_str(), "--json"],
        vec!["simulate", "--print-machine"],
    ] {
        let out = run_bounded(&args, closed_pipe());
        let se = String::from_utf8(out.stderr).unwrap();
        assert_eq!(out.status.code(), Some(0), "{args:?}: {se}");
        assert_eq!(se, "", "{args:?}");
    }
}

#[test]
fn full_stdout_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let b = blob(dir.path());
    let full = || Stdio::from(std::fs::File::create("/dev/full").unwrap());
    for args in [
        vec!["model", "show", "--model", b.as_str()],
        vec!["model", "show", "--model", b.as_str(), "--json"],
    ] {
        let out = run_bounded(&args, full());
        let se = String::from_utf8(out.stderr).unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}: {se}");
        assert_eq!(
            se, "error: cannot write to stdout: No space left on device (os error 28)\n",
            "{args:?}"
        );
    }
}

// ---- 3. an output that is an input is refused, the input kept --------------

/// Runs `args`, which name `victim` as both an input and an output: refused
/// with exactly `expected`, `victim` byte-identical afterwards.
fn refused_and_kept(args: &[&str], victim: &str, expected: &str) {
    let before = std::fs::read(victim).unwrap();
    fails_with(args, expected);
    assert_eq!(std::fs::read(victim).unwrap(), before, "{victim} changed");
}

fn same(out_flag: &str, out: &str, in_flag: &str, input: &str) -> String {
    format!("error: {out_flag} {out} is the same file as {in_flag} {input}: refusing to overwrite an input")
}

#[test]
fn output_equal_to_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = write(d, "run.csv", &run_text(200, false));
    // The same file by another spelling: refused as well.
    let data_alias = p(&d.join(".").join("run.csv")).to_string();
    let spec = write(d, "spec.toml", &std::fs::read_to_string(SP2_AMB).unwrap());
    let b = blob(d);
    let machine = write(
        d,
        "machine.toml",
        &common::ok(&["simulate", "--print-machine"]).0,
    );

    refused_and_kept(
        &[
            "predict",
            "--spec",
            &spec,
            "--data",
            &data,
            "--out",
            &data_alias,
        ],
        &data,
        &same("--out", &data_alias, "--data", &data),
    );
    refused_and_kept(
        &["model", "build", "--spec", &spec, "--out", &spec],
        &spec,
        &same("--out", &spec, "--spec", &spec),
    );
    refused_and_kept(
        &[
            "fit", "--data", &data, "--target", "dz_um", "--inputs", "T2", "--model", "mlr",
            "--out", &data,
        ],
        &data,
        &same("--out", &data, "--data", &data),
    );
    refused_and_kept(
        &[
            "fit",
            "--data",
            &data,
            "--target",
            "dz_um",
            "--model",
            "gain",
            "--gain-from",
            &b,
            "--out",
            &b,
        ],
        &b,
        &same("--out", &b, "--gain-from", &b),
    );
    refused_and_kept(
        &["refit", "--model", &b, "--data", &data, "--out", &data],
        &data,
        &same("--out", &data, "--data", &data),
    );
    refused_and_kept(
        &["replay", "--model", &b, "--data", &data, "--candump", &data],
        &data,
        &same("--candump", &data, "--data", &data),
    );
    refused_and_kept(
        &["replay", "--model", &b, "--data", &data, "--candump", &b],
        &b,
        &same("--candump", &b, "--model", &b),
    );
    let log = p(&d.join("out.log")).to_string();
    refused_and_kept(
        &[
            "replay",
            "--model",
            &b,
            "--data",
            &data,
            "--candump",
            &log,
            "--trace",
            &b,
        ],
        &b,
        &same("--trace", &b, "--model", &b),
    );
    refused_and_kept(
        &[
            "simulate",
            "--machine",
            &machine,
            "--out",
            &machine,
            "--hours",
            "0.1",
        ],
        &machine,
        &same("--out", &machine, "--machine", &machine),
    );
    let profile = format!("file:{data}");
    refused_and_kept(
        &["simulate", "--profile", &profile, "--out", &data],
        &data,
        &same("--out", &data, "--profile file:", &data),
    );
    refused_and_kept(
        &["simulate", "--calibrate", &data, "--save-machine", &data],
        &data,
        &same("--save-machine", &data, "--calibrate", &data),
    );
}

#[test]
fn two_outputs_on_one_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = write(d, "run.csv", &run_text(50, false));
    let b = blob(d);
    let log = p(&d.join("out.log")).to_string();
    fails_with(
        &["replay", "--model", &b, "--data", &data, "--candump", &log, "--trace", &log],
        &format!(
            "error: --trace {log} is the same file as --candump {log}: give each output its own file"
        ),
    );
    assert!(!Path::new(&log).exists());
}

#[test]
fn failed_run_keeps_the_old_output_whole() {
    // predict fails on a missing column after the output was opened in the
    // old code; now the old file stays and no temporary is left behind.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = write(d, "run.csv", "t_s,T1\n0,20\n1,21\n");
    let out = write(d, "pred.csv", "old predictions\n");
    let se = fails_one_line(&["predict", "--spec", SP2_AMB, "--data", &data, "--out", &out]);
    assert!(se.starts_with("error: "), "{se}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old predictions\n");
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 2);
}

// ---- 4. reads are bounded -------------------------------------------------

#[test]
fn devices_and_large_files_are_refused_early() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let big = d.join("big.bin");
    std::fs::write(&big, vec![0u8; 64 << 20]).unwrap();
    let big = p(&big).to_string();
    let out = p(&d.join("out.bin")).to_string();
    let data = write(d, "run.csv", &run_text(20, false));
    let blob_limit = "larger than 16384 bytes, the most this file kind can be";
    let text_limit = "larger than 1048576 bytes, the most this file kind can be";

    fails_with(
        &["model", "show", "--model", "/dev/zero"],
        &format!("error: /dev/zero: {blob_limit}"),
    );
    fails_with(
        &["model", "show", "--model", &big],
        &format!("error: {big}: {blob_limit}"),
    );
    fails_with(
        &["eval", "--model", "/dev/urandom", "--data", &data],
        &format!("error: /dev/urandom: {blob_limit}"),
    );
    fails_with(
        &["model", "build", "--spec", "/dev/zero", "--out", &out],
        &format!("error: /dev/zero: {text_limit}"),
    );
    fails_with(
        &["simulate", "--machine", "/dev/zero", "--out", &out],
        &format!("error: /dev/zero: {text_limit}"),
    );
    fails_with(
        &["eval", "--spec", SP2_AMB, "--data", "/dev/zero"],
        "error: /dev/zero:1: line longer than 1048576 bytes (not a run file?)",
    );
    fails_with(
        &["eval", "--spec", SP2_AMB, "--data", &big],
        &format!("error: {big}:1: line longer than 1048576 bytes (not a run file?)"),
    );
    // Random bytes: whatever the first complaint is, it comes at once.
    let out = run_bounded(
        &["eval", "--spec", SP2_AMB, "--data", "/dev/urandom"],
        Stdio::null(),
    );
    let se = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success());
    assert!(
        se.starts_with("error: /dev/urandom") && se.lines().count() == 1,
        "{se}"
    );
}

#[test]
fn too_many_columns_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let names: Vec<String> = (1..=10_001).map(|i| format!("c{i}")).collect();
    let data = write(
        dir.path(),
        "wide.csv",
        &format!("t_s,{}\n0{}\n", names.join(","), ",1".repeat(10_001)),
    );
    fails_with(
        &["eval", "--spec", SP2_AMB, "--data", &data],
        &format!("error: {data}:1: more than 10000 columns (not a run file?)"),
    );
}

// ---- 4. a grid that would be mostly interpolation --------------------------

/// Fails within [`DEADLINE`], its last stderr line exactly `expected`
/// (notes on what it was about to do may come before).
fn fails_ending_with(args: &[&str], expected: &str) {
    let out = run_bounded(args, Stdio::null());
    let se = String::from_utf8(out.stderr).unwrap();
    assert!(!out.status.success(), "thermcomp {args:?} should fail");
    assert_eq!(
        se.lines().last(),
        Some(expected),
        "thermcomp {args:?}: {se}"
    );
}

/// A run of 200 rows at 1 s whose second half was logged 104 days later (a
/// mistyped time, two runs in one file): resampling it on the model's 1 s
/// grid would build 9 million points from 200 rows. `fit`, `predict` and
/// `replay` refuse at once, naming the gap (before, `fit` ran out of its
/// two minutes at 4 GB, and `replay` wrote an 881 MB candump).
#[test]
fn a_gap_of_months_in_one_file_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = edited(&run_text(200, false), |i, c| {
        if i > 100 {
            c[0] = (c[0].parse::<f64>().unwrap() + 9e6).to_string();
        }
    });
    let data = write(d, "gap.csv", &text);
    let b = blob(d);
    let out = p(&d.join("out")).to_string();
    let refused = format!(
        "error: {data}: 200 rows resampled every 1 s would make 9000200 points, more \
         than 100 per row: the longest step between rows is 9000001 s (the median 1 s); \
         a run with a gap that long is two runs: split the file there"
    );
    let fit = [
        "fit", "--data", &data, "--target", "dz_um", "--inputs", "T1,T2", "--model", "arx",
        "--dt-s", "1", "--out", &out,
    ];
    fails_ending_with(&fit, &refused);
    fails_ending_with(
        &["predict", "--model", &b, "--data", &data, "--out", &out],
        &refused,
    );
    fails_ending_with(
        &["replay", "--model", &b, "--data", &data, "--candump", &out],
        &refused,
    );
    assert!(!d.join("out").exists());
}

// ---- 5. flags that cannot mean what they say --------------------------------

/// A validation run that is a calibration run, an output in a directory
/// that does not exist, names given twice and a holdout time that is not a
/// time: each refused in one line before any work, naming what is wrong.
#[test]
fn contradictory_or_impossible_flags_are_refused_before_the_fit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = write(d, "run.csv", &run_text(200, false));
    let alias = p(&d.join(".").join("run.csv")).to_string();
    let out = p(&d.join("m.bin")).to_string();
    let fit = |extra: &[&str]| -> Vec<String> {
        [
            "fit", "--data", &data, "--target", "dz_um", "--model", "mlr",
        ]
        .iter()
        .chain(extra)
        .map(|s| s.to_string())
        .collect()
    };
    let fails_with = |args: Vec<String>, expected: &str| {
        fails_with(
            &args.iter().map(String::as_str).collect::<Vec<_>>(),
            expected,
        );
    };
    fails_with(
        fit(&["--inputs", "T1", "--validate", &alias, "--out", &out]),
        &format!(
            "error: --validate {alias} is the same file as --data {data}: its figures would \
             not be held out"
        ),
    );
    let nowhere = p(&d.join("no").join("m.bin")).to_string();
    fails_with(
        fit(&["--inputs", "T1", "--out", &nowhere]),
        &format!(
            "error: cannot write {nowhere}: there is no directory {}",
            p(&d.join("no"))
        ),
    );
    fails_with(
        fit(&["--inputs", "T1,T2,T1", "--out", &out]),
        "error: --inputs names T1 twice (positions 1 and 3)",
    );
    fails_with(
        fit(&["--inputs", "T1", "--holdout-from-s", "NaN", "--out", &out]),
        "error: --holdout-from-s NaN: give a time in seconds",
    );
    assert!(!d.join("m.bin").exists());
}

/// An input beyond the hub's 1e9 limit (the reader takes up to 1e15 in a
/// column whose name states no quantity) gets no prediction, and the note
/// says why (it used to say "non-finite output", which it was not). In a
/// column named as a temperature the same cell is refused where it stands.
#[test]
fn an_input_the_hub_refuses_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = edited(&run_text(50, false), |i, c| {
        if i == 0 {
            c[2] = "raw1".into();
        } else {
            c[2] = "3e9".into();
        }
    });
    let data = write(d, "big.csv", &text);
    let b = blob(d);
    let out = p(&d.join("p.csv")).to_string();
    let r = run_bounded(
        &[
            "predict", "--model", &b, "--data", &data, "--map", "T1=raw1", "--out", &out,
        ],
        Stdio::null(),
    );
    let se = String::from_utf8(r.stderr).unwrap();
    assert!(r.status.success(), "{se}");
    assert!(
        se.contains(&format!(
            "note: {data}: 50 of 50 samples have an input beyond 1e9 in magnitude, which the \
             hub refuses as a broken reading: no prediction there"
        )),
        "{se}"
    );
    assert!(!se.contains("non-finite"), "{se}");
    let named = write(d, "t1.csv", &text.replacen("raw1", "T1", 1));
    fails_with(
        &["predict", "--model", &b, "--data", &named, "--out", &out],
        &format!(
            "error: {named}:2:3 (T1): value \"3e9\" is not a temperature in deg C (its name \
             says so; readings lie in -273.15 ..= 1000)"
        ),
    );
}

/// A `--map` NAME the model neither reads nor predicts, or one NAME mapped
/// twice, is refused (both used to be ignored without a word); so is a
/// COLUMN that is the time.
#[test]
fn a_map_that_cannot_apply_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = write(d, "run.csv", &run_text(50, false));
    let b = blob(d);
    fails_with(
        &["eval", "--model", &b, "--data", &data, "--map", "T9=T2"],
        "error: --map T9=T2: the model has no input or output T9 (inputs: T1, ambient_c; \
         outputs: dz_um)",
    );
    fails_with(
        &[
            "predict",
            "--model",
            &b,
            "--data",
            &data,
            "--map",
            "T1=T2",
            "--map",
            "T1=speed_rpm",
            "--out",
            p(&d.join("p.csv")),
        ],
        "error: --map T1=speed_rpm: T1 is mapped twice (to T2 and to speed_rpm)",
    );
    // The time column is neither (it was "the run has no such column").
    fails_with(
        &["eval", "--model", &b, "--data", &data, "--map", "dz_um=t_s"],
        "error: --map dz_um=t_s: t_s is the run's time, not an input or a measured column",
    );
}

/// Default inputs come from the headers alone: a row with one field too
/// many is a `file:line` error even then (the header read used to skip
/// every row and report "no valid data rows (all N skipped ...)" without
/// --skip-bad-rows); and they are the columns every run has, whichever
/// run comes first (a column only the first run had used to be refused
/// in the other run, one only the second had silently dropped).
#[test]
fn default_inputs_come_from_every_run_s_header() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let full = run_text(60, false);
    let trailing = edited(&full, |i, c| {
        if i > 0 {
            c.push(String::new());
        }
    });
    let bad = write(d, "trailing.csv", &trailing);
    let out = p(&d.join("m.bin")).to_string();
    fails_with(
        &[
            "fit", "--data", &bad, "--target", "dz_um", "--model", "mlr", "--out", &out,
        ],
        &format!("error: {bad}:2: expected 6 fields, found 7"),
    );
    // The second run without T2.
    let no_t2 = edited(&full, |_, c| {
        c.remove(3);
    });
    let (a, b) = (write(d, "a.csv", &full), write(d, "b.csv", &no_t2));
    for (first, second) in [(&a, &b), (&b, &a)] {
        let r = run_bounded(
            &[
                "fit", "--data", first, "--data", second, "--target", "dz_um", "--model", "mlr",
                "--out", &out,
            ],
            Stdio::null(),
        );
        let se = String::from_utf8(r.stderr).unwrap();
        assert!(r.status.success(), "{se}");
        assert!(se.contains("linear model on 1 inputs"), "{se}");
        assert_eq!(
            se.contains(&format!(
                "note: T2 is not in {b}: not among the default inputs"
            )),
            first == &a,
            "{se}"
        );
    }
}

/// A closed stderr (`thermcomp ... 2>&1 | head`) drops the notes, not the
/// work: the command finishes and writes its output (std's `eprintln!`
/// panicked on the broken pipe, exit 101, mid-work).
#[test]
fn closed_stderr_pipe_drops_the_notes_not_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run.csv");
    let status = Command::new(env!("CARGO_BIN_EXE_thermcomp"))
        .args(["simulate", "--out", p(&out), "--hours", "0.5"])
        .stdin(Stdio::null())
        .stdout(closed_pipe())
        .stderr(closed_pipe())
        .status()
        .unwrap();
    assert_eq!(status.code(), Some(0));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.lines().count() > 100, "{}", text.lines().count());
}

/// A dynamic model's run given as a FIFO: the first pass read it, the
/// second waited for a writer for ever. Now refused at once, before any
/// open, with one line (nothing writes to the FIFO here, so even the first
/// open would block).
#[test]
fn a_fifo_run_for_a_dynamic_model_is_refused_not_waited_on() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = d.join("run.fifo");
    nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
    let b = blob(d);
    let out = p(&d.join("p.csv")).to_string();
    fails_with(
        &["predict", "--model", &b, "--data", p(&fifo), "--out", &out],
        &format!(
            "error: {}: a pipe or FIFO: a dynamic model reads its run twice (its time steps \
             first), so give the run as a file",
            p(&fifo)
        ),
    );
}

/// `eval` over two runs, one whose target is empty on every row: its text
/// line says why it has no figures (it printed `rmse NaN  fit NaN%`), as the
/// JSON does.
#[test]
fn a_run_with_nothing_to_score_has_no_nan_figures() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = write(d, "good.csv", &run_text(50, false));
    let empty = edited(&run_text(50, false), |i, c| {
        if i > 0 {
            c[5].clear();
        }
    });
    let empty = write(d, "empty.csv", &empty);
    let b = blob(d);
    let (table, _) = common::ok(&["eval", "--model", &b, "--data", &good, "--data", &empty]);
    let line = table
        .lines()
        .find(|l| l.trim_start().starts_with(&empty))
        .unwrap_or_else(|| panic!("{table}"));
    assert!(!table.contains("NaN"), "{table}");
    assert!(line.contains("no samples"), "{line}");
}

/// `predict` over several runs writes each run's file name in the `run`
/// column as one CSV field, whole: a comma used to become `_`, and a line
/// break split the row in two.
#[test]
fn run_names_with_commas_quotes_and_line_breaks_stay_one_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = run_text(20, false);
    let odd = [
        write(d, "a,b \"q\".csv", &text),
        write(d, "nl\nname.csv", &text),
    ];
    let b = blob(d);
    let out = d.join("p.csv");
    let r = run_bounded(
        &[
            "predict",
            "--model",
            &b,
            "--data",
            &odd[0],
            "--data",
            &odd[1],
            "--out",
            p(&out),
        ],
        Stdio::null(),
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let mut rdr = csv::Reader::from_path(&out).unwrap();
    let runs: Vec<String> = rdr
        .records()
        .map(|rec| {
            let rec = rec.unwrap();
            assert_eq!(rec.len(), 3, "{rec:?}");
            rec[0].to_string()
        })
        .collect();
    assert_eq!(runs.len(), 40);
    assert!(runs[..20].iter().all(|r| *r == odd[0]), "{:?}", runs[0]);
    assert!(runs[20..].iter().all(|r| *r == odd[1]), "{:?}", runs[20]);
}

/// A broken reading in a calibration run (900 C for one row among 20 C
/// ones) is named by `fit`, which takes it as a figure (it said nothing),
/// and in a real run by `diagnose`.
#[test]
fn a_broken_reading_in_the_calibration_runs_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // `rows` rows of run_text, T2 at 900 C on line 10 (t_s = 9) if `spike`.
    let run = |name: &str, rows: usize, spike: bool| {
        let text = edited(&run_text(rows, false), |i, c| {
            if spike && i == 10 {
                c[3] = "900".into();
            }
        });
        write(d, name, &text)
    };
    let out = p(&d.join("m.bin")).to_string();
    let fit = |data: &str| {
        common::ok(&[
            "fit", "--data", data, "--model", "mlr", "--inputs", "T1,T2", "--target", "dz_um",
            "--out", &out,
        ])
        .1
    };
    let data = run("spike.csv", 50, true);
    let se = fit(&data);
    assert!(
        se.contains(&format!(
            "note: {data}: T2: 1 reading(s) jump away from both neighbours faster than a \
             temperature moves (the first 900 at t_s = 9): broken readings? The fit takes them"
        )) && se.matches("jump away").count() == 1,
        "{se}"
    );
    let se = fit(&run("clean.csv", 50, false));
    assert!(!se.contains("jump away"), "{se}");
    // diagnose names it in the real run too.
    let sim = run("sim.csv", 400, false);
    let real = run("real.csv", 400, true);
    let r = run_bounded(
        &["diagnose", "--sim", &sim, "--real", &real, "--json"],
        Stdio::null(),
    );
    let se = String::from_utf8(r.stderr).unwrap();
    assert!(r.status.success(), "{se}");
    assert!(
        se.contains(&format!("note: {real}: T2: 1 reading(s) jump away"))
            && se.contains("The diagnosis takes them")
            && se.matches("jump away").count() == 1,
        "{se}"
    );
}
