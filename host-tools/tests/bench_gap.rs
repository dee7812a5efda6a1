//! A reduced blind benchmark of `thermcomp diagnose` (docs/gap-benchmark.md):
//! every cause (five effects and `none`), the 24 h spectrum profile, three
//! magnitudes, logged and unlogged boundary temperatures, one seed each, on
//! a machine with eight parameters drawn within +-4 %: 36 cases. The base
//! seed (4242) was never used while developing the diagnosis or choosing
//! these thresholds (development used seed 1; docs/gap-benchmark.md), so
//! this is a held-out check of the rule, not a replay. With the calibrated
//! rule (mismatch baseline, block-bootstrap significance; docs/diagnose.md
//! section 3) it gives 35 of 36, no false alarm, median shrink 90.2 %.
//!
//! The full benchmark (324 cases, 3 profiles) runs in release:
//! `thermcomp bench gap --twin --seed 3 --out DIR` (23-31 s). This file takes
//! 50-75 s in debug on a shared 2-core box.

mod common;

use common::{fails_one_line, ok_json};
use host_tools::bench::cases::{self, GapConfig, ProfileSpec, LABELS};
use host_tools::bench::gap::{run_all, summarise};

/// Seed of the test set: not a development seed.
const TEST_SEED: u64 = 4242;

#[test]
fn blind_benchmark_identifies_most_effects_with_few_false_alarms() {
    let started = std::time::Instant::now();
    let cfg = GapConfig {
        effects: LABELS.iter().map(|s| s.to_string()).collect(),
        profiles: vec![ProfileSpec::parse("spectrum:24").unwrap()],
        magnitudes: vec![0.5, 1.0, 2.0],
        seeds: 1,
        mismatch_pct: 4.0,
        seed: TEST_SEED,
    };
    let all = cases::cases(&cfg).unwrap();
    assert_eq!(all.len(), 36);
    let dir = tempfile::tempdir().unwrap();
    let outs = run_all(all, dir.path(), false).unwrap();
    let s = summarise(&outs);
    let wrong: Vec<String> = outs
        .iter()
        .filter(|o| !o.correct())
        .map(|o| format!("{} -> {}", o.case.effect, o.diag.verdict))
        .collect();
    eprintln!(
        "bench_gap: {} cases in {:.1} s, accuracy {:.1} %, false alarms {}/{}, median shrink {:.1} %, wrong: {wrong:?}",
        outs.len(),
        started.elapsed().as_secs_f64(),
        s.accuracy_pct,
        s.false_alarms.0,
        s.false_alarms.1,
        s.median_shrink_correct_pct
    );
    // Pass mark 1: >= 80 % of all cases right. With the final diagnosis the
    // development seed gave 98.1 % on this profile (106 of 108; 90-92 % with
    // the diagnosis as it was before the benchmark), the full benchmark
    // 93.8 % on fresh seeds. 80 % leaves room for ~4 wrong of 36 on a new
    // seed while still failing if one cause were systematically missed
    // (6 of 36).
    assert!(s.accuracy_pct >= 80.0, "accuracy {:.1} %", s.accuracy_pct);
    // Pass mark 2: <= 1 false alarm among the 6 `none` cases. Development:
    // 1 of 18 on this profile; full benchmark 2-4 of 54 (4-7 %). One in six
    // is the most a user should accept from a tool whose verdict sends them
    // to model an effect.
    assert!(s.false_alarms.0 <= 1, "false alarms {:?}", s.false_alarms);
    // Pass mark 3: the correctly identified effects shrink the held-out gap
    // by >= 60 % (median). Development: 86.3 % on this profile; the rule
    // itself only asks 20 %, so a median far above it shows the verdicts
    // are not scraped through the rule.
    assert!(
        s.median_shrink_correct_pct >= 60.0,
        "median shrink {:.1} %",
        s.median_shrink_correct_pct
    );
    // Every cause is identified at least once (no candidate is dead).
    for (i, l) in LABELS.iter().enumerate() {
        assert!(
            s.confusion[i][i] >= 1,
            "{l} never identified: {:?}",
            s.confusion
        );
    }
}

#[test]
fn bench_gap_cli_writes_its_files_and_one_json_object() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let v = ok_json(&[
        "bench",
        "gap",
        "--twin",
        "--quick",
        "--profiles",
        "spectrum:12",
        "--magnitudes",
        "1",
        "--cases",
        "6",
        "--seed",
        "4243",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(v["cases"], 6);
    let per = v["per_case"].as_array().unwrap();
    assert_eq!(per.len(), 6);
    for c in per {
        for k in [
            "effect",
            "profile",
            "verdict",
            "seed",
            "magnitude",
            "logged",
            "shrink_pct",
        ] {
            assert!(!c[k].is_null(), "{k} in {c}");
        }
    }
    let total: u64 = LABELS
        .iter()
        .map(|r| {
            LABELS
                .iter()
                .map(|c| v["confusion"][r][c].as_u64().unwrap())
                .sum::<u64>()
        })
        .sum();
    assert_eq!(total, 6, "the confusion matrix counts every case once");
    for f in ["cases.csv", "confusion.md", "summary.json", "confusion.svg"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    assert!(!out.join("runs").exists(), "run files are removed");
    let csv = std::fs::read_to_string(out.join("cases.csv")).unwrap();
    assert_eq!(csv.lines().count(), 7);
}

#[test]
fn bench_gap_bad_flags_fail_with_one_line() {
    let e = fails_one_line(&["bench", "gap", "--twin", "--profiles", "spectrum"]);
    assert!(e.contains("NAME:HOURS"), "{e}");
    let e = fails_one_line(&["bench", "gap", "--twin", "--effects", "rain"]);
    assert!(e.contains("rain"), "{e}");
    let e = fails_one_line(&["bench", "gap", "--twin", "--magnitudes", "x"]);
    assert!(e.contains("--magnitudes"), "{e}");
}
