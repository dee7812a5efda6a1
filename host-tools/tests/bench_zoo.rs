//! `thermcomp bench gap` on the plant zoo (docs/gap-benchmark.md, "Plant
//! zoo"): the command's shape, the held-out plant's handling and its
//! errors. These tests do not judge the diagnosis: a smoke run has a few
//! cases per plant, far too few for an accuracy to mean anything, so only
//! that it is a number in [0, 1] is checked. The zoo's physics is tested
//! in its modules (`cargo test -p host-tools --lib zoo`).

mod common;

use common::{fails_one_line, ok_json};
use host_tools::bench::zoo::catalogue::DEFAULT_HELDOUT;
use serde_json::Value;

const LABELS: [&str; 6] = [
    "ambient",
    "coolant",
    "cutting",
    "motor_loss",
    "sensor_lag",
    "none",
];

/// A rate: null (undefined) or a number in [0, 1].
fn is_rate(v: &Value) -> bool {
    v.is_null() || v.as_f64().is_some_and(|x| (0.0..=1.0).contains(&x))
}

/// Sum of a confusion matrix object.
fn confusion_total(c: &Value) -> u64 {
    LABELS
        .iter()
        .map(|r| {
            LABELS
                .iter()
                .map(|v| c[r][v].as_u64().unwrap())
                .sum::<u64>()
        })
        .sum()
}

#[test]
fn zoo_smoke_run_has_per_plant_scores_and_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("zoo");
    let v = ok_json(&[
        "bench",
        "gap",
        "--zoo",
        "--quick",
        "--plants",
        "a,c",
        "--hours",
        "24",
        "--seed",
        "7",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(v["benchmark"], "zoo");
    assert_eq!(v["heldout_plant"], DEFAULT_HELDOUT);
    assert_eq!(v["scored_heldout"], false);
    assert_eq!(v["cases"], 12, "one case per cause on each of 2 plants");
    let plants = v["plants"].as_array().unwrap();
    let ids: Vec<&str> = plants
        .iter()
        .map(|p| p["plant"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["a", "c"]);
    for p in plants.iter().chain(std::iter::once(&v["pooled"])) {
        let acc = p["accuracy"].as_f64().expect("accuracy is a number");
        assert!((0.0..=1.0).contains(&acc), "{acc}");
        for k in ["false_alarm_rate", "wrong_effect_rate", "miss_rate"] {
            assert!(is_rate(&p[k]), "{k}: {}", p[k]);
        }
        assert_eq!(
            confusion_total(&p["confusion"]),
            p["cases"].as_u64().unwrap()
        );
        assert!(
            p["median_shrink_correct_pct"].is_null() || p["median_shrink_correct_pct"].is_number()
        );
    }
    assert_eq!(v["plant_facts"].as_array().unwrap().len(), 2);
    let per = v["per_case"].as_array().unwrap();
    assert_eq!(per.len(), 12);
    for c in per {
        for k in [
            "plant",
            "effect",
            "profile",
            "seed",
            "magnitude",
            "logged",
            "verdict",
            "correct",
        ] {
            assert!(!c[k].is_null(), "{k} in {c}");
        }
        assert!(
            c["plant"] != DEFAULT_HELDOUT,
            "the held-out plant never runs in development"
        );
    }
    for f in [
        "cases.csv",
        "zoo.md",
        "summary.json",
        "confusion-a.svg",
        "confusion-c.svg",
        "confusion-all.svg",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    assert!(!out.join("runs").exists(), "run files are removed");
    let csv = std::fs::read_to_string(out.join("cases.csv")).unwrap();
    assert_eq!(csv.lines().count(), 13);
}

#[test]
fn score_heldout_runs_only_the_heldout_plant() {
    // Plant c designated held out for this test only (the real held-out
    // plant, f, is scored once by hand at the end of development).
    let v = ok_json(&[
        "bench",
        "gap",
        "--score-heldout",
        "--heldout-plant",
        "c",
        "--quick",
        "--effects",
        "cutting,none",
        "--hours",
        "24",
        "--json",
    ]);
    assert_eq!(v["scored_heldout"], true);
    assert_eq!(v["heldout_plant"], "c");
    let ids: Vec<&str> = v["plants"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["plant"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["c"]);
    assert_eq!(v["cases"], 2);
    assert!(v["per_case"]
        .as_array()
        .unwrap()
        .iter()
        .all(|c| c["plant"] == "c"));
}

#[test]
fn zoo_flags_fail_with_one_line() {
    // Naming the default held-out plant among the development plants is
    // refused before any case runs.
    let with_heldout = format!("a,{DEFAULT_HELDOUT}");
    let e = fails_one_line(&["bench", "gap", "--plants", &with_heldout]);
    assert!(
        e.contains("held out") && e.contains("--score-heldout"),
        "{e}"
    );
    let e = fails_one_line(&["bench", "gap", "--plants", "q"]);
    assert!(e.contains("unknown plant \"q\""), "{e}");
    let e = fails_one_line(&["bench", "gap", "--heldout-plant", "q"]);
    assert!(e.contains("--heldout-plant"), "{e}");
    let e = fails_one_line(&["bench", "gap", "--effects", "rain"]);
    assert!(e.contains("rain"), "{e}");
    let e = fails_one_line(&["bench", "gap", "--hours", "2"]);
    assert!(e.contains("--hours"), "{e}");
    let e = fails_one_line(&["bench", "gap", "--twin", "--plants", "a"]);
    assert!(e.contains("--twin"), "{e}");
    let e = fails_one_line(&["bench", "gap", "--profiles", "steps:48"]);
    assert!(e.contains("--twin"), "twin-only flags ask for --twin: {e}");
    // Also beside a zoo flag, where clap lets them through (`--cases 2
    // --plants a` ran every zoo case without a word).
    for flag in ["--cases", "--seeds"] {
        let e = fails_one_line(&["bench", "gap", flag, "2", "--plants", "a"]);
        assert!(e.contains(&format!("{flag} is for the twin cases")), "{e}");
    }
    let e = fails_one_line(&["bench", "gap", "--effects", "ambient,ambient"]);
    assert!(e.contains("--effects: ambient is listed twice"), "{e}");
    let e = fails_one_line(&["bench", "gap", "--twin", "--cases", "0"]);
    assert!(e.contains("--cases must be at least 1"), "{e}");
}

/// `--out DIR` never removes what the run did not create: a user's files
/// in `DIR/runs` survive a run without `--keep-runs` (the folder used to be
/// removed, files and all), and `--keep-runs` refuses to write into it.
#[test]
fn a_user_s_runs_folder_is_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("zoo");
    let precious = out.join("runs").join("precious.csv");
    std::fs::create_dir_all(precious.parent().unwrap()).unwrap();
    std::fs::write(&precious, "t_s\n0\n").unwrap();
    let args = [
        "bench",
        "gap",
        "--quick",
        "--plants",
        "a",
        "--hours",
        "24",
        "--out",
        out.to_str().unwrap(),
    ];
    common::ok(&args);
    assert_eq!(std::fs::read_to_string(&precious).unwrap(), "t_s\n0\n");
    assert_eq!(std::fs::read_dir(out.join("runs")).unwrap().count(), 1);
    let mut keep = args.to_vec();
    keep.push("--keep-runs");
    let e = fails_one_line(&keep);
    assert!(e.contains("exists and is not an empty folder"), "{e}");
    assert!(precious.is_file());
}
