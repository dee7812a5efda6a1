//! `thermcomp select` end to end: the three methods on a real run
//! (FL_THERMAL, 46 h, 16 temperatures), seed 002 Eq. 1 against an
//! independent numpy computation on the paper's own Figure 3 rows, and the
//! command line's errors and notes.

mod common;

use common::{fails_one_line as fails, ok, write, FL_THERMAL};
use serde_json::Value;
use std::collections::BTreeSet;

const SEED002_FIG3: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../tests/data/seed002_fig3.csv"
);

/// Runs with `--json`; returns the parsed object and stderr.
fn json(args: &[&str]) -> (Value, String) {
    let mut a = args.to_vec();
    a.push("--json");
    let (so, se) = ok(&a);
    assert_eq!(so.trim_end().lines().count(), 1, "one JSON object: {so}");
    (serde_json::from_str(&so).expect("JSON on stdout"), se)
}

fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|s| s.as_str().expect("string").to_string())
        .collect()
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|s| s.as_f64().expect("number"))
        .collect()
}

fn temps() -> BTreeSet<String> {
    (1..=16).map(|i| format!("T{i}")).collect()
}

#[test]
fn fl_thermal_every_method_selects_a_subset_of_t1_to_t16() {
    for method in ["grey", "wgrey", "maxtree"] {
        let (v, _) = json(&[
            "select", "--data", FL_THERMAL, "--target", "ch1_um", "--method", method,
        ]);
        assert_eq!(v["method"], method);
        assert_eq!(strings(&v["target"]), ["ch1_um"]);
        assert_eq!(strings(&v["inputs"]).len(), 16, "default inputs: T<number>");
        let sel = strings(&v["selected"]);
        assert!(!sel.is_empty(), "{method}: nothing selected");
        let set: BTreeSet<String> = sel.iter().cloned().collect();
        assert_eq!(set.len(), sel.len(), "{method}: duplicates in {sel:?}");
        assert!(set.is_subset(&temps()), "{method}: {sel:?}");
    }
}

#[test]
fn fl_thermal_maxtree_levels() {
    let (v, _) = json(&[
        "select", "--data", FL_THERMAL, "--target", "ch1_um", "--method", "maxtree",
    ]);
    let tree = v["tree"].as_array().unwrap();
    assert_eq!(tree.len(), 15, "a spanning tree of 16 variables");
    let mut weights: Vec<f64> = tree.iter().map(|e| e["weight"].as_f64().unwrap()).collect();
    weights.sort_by(f64::total_cmp);
    weights.dedup();
    let levels = v["levels"].as_array().unwrap();
    assert_eq!(
        levels.len(),
        weights.len(),
        "one level per distinct edge weight"
    );
    // Ascending lambda, each level the partition keeping edges >= lambda:
    // the first is one group of all 16, then one more group per level.
    let lambdas: Vec<f64> = levels
        .iter()
        .map(|l| l["lambda"].as_f64().unwrap())
        .collect();
    assert_eq!(lambdas, weights);
    for (k, l) in levels.iter().enumerate() {
        let groups: Vec<Vec<String>> = l["groups"]
            .as_array()
            .unwrap()
            .iter()
            .map(strings)
            .collect();
        let all: Vec<&String> = groups.iter().flatten().collect();
        let set: BTreeSet<String> = all.iter().map(|s| s.to_string()).collect();
        assert_eq!(all.len(), 16, "level {k} lists each variable once");
        assert_eq!(set, temps(), "level {k} partitions T1..T16");
        assert_eq!(groups.len(), k + 1, "level {k}");
        // One representative per group.
        assert_eq!(strings(&l["representatives"]).len(), groups.len());
    }
    // The selection is the chosen level's representatives.
    let chosen = v["chosen_level"].as_u64().unwrap() as usize;
    assert_eq!(
        strings(&v["selected"]),
        strings(&levels[chosen]["representatives"])
    );
    // Matrices come in the inputs' order, symmetric with a unit diagonal.
    let sim = v["similarity"].as_array().unwrap();
    assert_eq!(sim.len(), 16);
    for (i, row) in sim.iter().enumerate() {
        let row = numbers(row);
        assert_eq!(row[i], 1.0);
        for (j, x) in row.iter().enumerate() {
            assert_eq!(*x, sim[j][i].as_f64().unwrap());
        }
    }
}

#[test]
fn fl_thermal_grey_table() {
    let (v, se) = json(&[
        "select", "--data", FL_THERMAL, "--target", "ch1_um", "--method", "grey",
    ]);
    // ch1_um starts at 0.377 um and reaches 25 um: the note explains why
    // initial-value processing is a poor fit for it.
    assert!(se.contains("initial-value processing divides"), "{se}");
    let k = strings(&v["typical"]).len();
    let combos = v["combinations"].as_array().unwrap();
    assert_eq!(combos.len(), (1 << k) - 1);
    // The selection is the combination with the best adjusted R^2.
    let best = combos
        .iter()
        .max_by(|a, b| {
            a["adj_r2"]
                .as_f64()
                .unwrap()
                .total_cmp(&b["adj_r2"].as_f64().unwrap())
        })
        .unwrap();
    assert_eq!(strings(&best["variables"]), strings(&v["selected"]));
    // Every input is in exactly one group.
    let n: usize = v["groups"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| strings(g).len())
        .sum();
    assert_eq!(n, 16);
    for key in ["absolute", "relative", "comprehensive"] {
        assert_eq!(v[key].as_array().unwrap().len(), 16, "{key}");
    }
}

/// Seed 002 Eq. 1 (xi = lambda1 = lambda2 = 0.5) on the 26 rows of the
/// paper's Figure 3, targets S1 and S2, checked against an independent
/// computation: numpy 2.4.6 (Python 3.11.7), written straight from Eq. 1 with
/// the same conventions (k over the samples with a predecessor, D_max over
/// the same samples, processing per run):
///
/// ```python
/// def eq1(x0, X, xi=0.5, l1=0.5, l2=0.5):
///     D = np.abs(x0[1:] - X[:, 1:])
///     Dd = np.abs(np.diff(x0) - np.diff(X, axis=1))
///     dmax = D.max()
///     return (xi * dmax / (l1 * D + l2 * Dd + xi * dmax)).mean(axis=1)
/// ```
///
/// Interval processing `(x - min) / (max - min)` and mean processing
/// `x / mean(x)`; S1 and S2 start at 0, so the default initial-value
/// processing is undefined for them (tested below). These are not the
/// paper's gammas, which came from 6 groups of 90 points.
/// Tolerance 1e-9: the same arithmetic in another order.
#[test]
fn seed002_fig3_matches_numpy() {
    let cases: [(&str, &str, [f64; 16], [&str; 6]); 4] = [
        (
            "interval",
            "S1",
            [
                0.5192987094081088,
                0.5461151548361848,
                0.5917983812312171,
                0.5541454256110872,
                0.5737863741894763,
                0.5338934772784942,
                0.5258972898031848,
                0.5380715654889476,
                0.5817040566349276,
                0.620724432866112,
                0.5769800815503263,
                0.5905592485693615,
                0.5988011836978887,
                0.5059581525168505,
                0.5380429407026671,
                0.5194455505286166,
            ],
            ["T10", "T13", "T3", "T12", "T9", "T11"],
        ),
        (
            "interval",
            "S2",
            [
                0.6173979467026047,
                0.5769327461829727,
                0.539356147051976,
                0.6422306726774551,
                0.6073402710616462,
                0.5734101948848164,
                0.5581829161548598,
                0.5845271580678658,
                0.5873468015558628,
                0.5498647272850203,
                0.5656618624467867,
                0.5214506881534723,
                0.5297984385612778,
                0.577625859548071,
                0.5845003975679401,
                0.6173601985075654,
            ],
            ["T4", "T1", "T16", "T5", "T9", "T8"],
        ),
        (
            "mean",
            "S1",
            [
                0.6519228673816948,
                0.6522999021431554,
                0.6520861777439585,
                0.6518624063202106,
                0.6519849461297845,
                0.6518403577233848,
                0.6521956829542519,
                0.6506101638916274,
                0.6520394534359297,
                0.65209562310898,
                0.6519438396617602,
                0.652062196526945,
                0.6520261210135159,
                0.6522012827401409,
                0.6506195379856723,
                0.6519187298699662,
            ],
            ["T2", "T14", "T7", "T10", "T3", "T12"],
        ),
        (
            "mean",
            "S2",
            [
                0.6502273354221758,
                0.6503362482588309,
                0.6501817252384154,
                0.6497320174478628,
                0.6498630813179223,
                0.6502657953641399,
                0.6500763800229532,
                0.6488054654846366,
                0.6506235426958246,
                0.6498394219311935,
                0.6500480455104717,
                0.6499768780612191,
                0.6502566767032313,
                0.6500708546196862,
                0.648812212758555,
                0.6502171813761656,
            ],
            ["T9", "T2", "T6", "T13", "T1", "T16"],
        ),
    ];
    for scale in ["interval", "mean"] {
        let (v, _) = json(&[
            "select",
            "--data",
            SEED002_FIG3,
            "--target",
            "S1,S2",
            "--method",
            "wgrey",
            "--scale",
            scale,
        ]);
        assert_eq!(strings(&v["target"]), ["S1", "S2"]);
        let mut tops = Vec::new();
        for (_, target, want, top) in cases.iter().filter(|c| c.0 == scale) {
            let t = &v["per_target"][*target];
            let got = numbers(&t["gamma"]);
            for (i, (g, w)) in got.iter().zip(want).enumerate() {
                assert!(
                    (g - w).abs() <= 1e-9,
                    "{scale} {target} T{}: {g} vs {w}",
                    i + 1
                );
            }
            assert_eq!(strings(&t["top"]), top, "{scale} {target}");
            tops.push(top.iter().map(|s| s.to_string()).collect::<BTreeSet<_>>());
        }
        // Selected: the inputs in both targets' top six (seed 002's rule).
        let both: BTreeSet<String> = tops[0].intersection(&tops[1]).cloned().collect();
        let sel: BTreeSet<String> = strings(&v["selected"]).into_iter().collect();
        assert_eq!(sel, both, "{scale}");
    }
}

/// Initial-value processing and non-default weights, same numpy reference
/// (numpy 2.4.6): target T1, inputs T2..T16, xi 0.4, lambda1 0.7, lambda2 0.3.
#[test]
fn seed002_fig3_initial_value_and_weights_match_numpy() {
    let want = [
        0.6039123546856137,
        0.6319192640955369,
        0.6590499859494783,
        0.6890470398504454,
        0.6047179095326835,
        0.5623781606145577,
        0.7669438973627173,
        0.5742424338492902,
        0.6048615191058605,
        0.6350243348866556,
        0.5695246428361359,
        0.5994956666885496,
        0.5621050134280837,
        0.7672523488748059,
        0.9965752162007504,
    ];
    let inputs: Vec<String> = (2..=16).map(|i| format!("T{i}")).collect();
    let inputs = inputs.join(",");
    let (v, _) = json(&[
        "select",
        "--data",
        SEED002_FIG3,
        "--target",
        "T1",
        "--inputs",
        &inputs,
        "--method",
        "wgrey",
        "--xi",
        "0.4",
        "--lambda1",
        "0.7",
        "--lambda2",
        "0.3",
        "--top",
        "3",
    ]);
    let got = numbers(&v["per_target"]["T1"]["gamma"]);
    assert_eq!(got.len(), 15);
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() <= 1e-9, "{g} vs {w}");
    }
    assert_eq!(strings(&v["selected"]), ["T8", "T15", "T16"]);
}

/// Seed 002 Eq. 1 gammas of T1..T16 with target S1 under interval
/// processing, default weights: the numpy 2.4.6 reference of
/// `seed002_fig3_matches_numpy`.
const S1_INTERVAL_GAMMAS: [f64; 16] = [
    0.5192987094081088,
    0.5461151548361848,
    0.5917983812312171,
    0.5541454256110872,
    0.5737863741894763,
    0.5338934772784942,
    0.5258972898031848,
    0.5380715654889476,
    0.5817040566349276,
    0.620724432866112,
    0.5769800815503263,
    0.5905592485693615,
    0.5988011836978887,
    0.5059581525168505,
    0.5380429407026671,
    0.5194455505286166,
];

/// The fallback reported in JSON: S1 started at 0, and interval processing
/// took over for S1 and every input.
fn assert_fell_back_for_s1(fallback: &Value, inputs: usize) {
    assert_eq!(fallback["from"], "initial", "{fallback}");
    assert_eq!(fallback["to"], "interval", "{fallback}");
    assert_eq!(strings(&fallback["zero_start"]), ["S1"], "{fallback}");
    let series = strings(&fallback["series"]);
    assert_eq!(series.len(), inputs + 1, "{fallback}");
    assert!(series.contains(&"S1".to_string()), "{fallback}");
}

#[test]
fn wgrey_with_a_target_starting_at_0_falls_back_to_interval_processing() {
    // S1 starts at exactly 0: the default --scale initial used to fail.
    // It now ranks the sensors with interval processing for the whole
    // computation, says so on stderr and in JSON, and gives exactly what
    // --scale interval gives (the numpy gammas within 1e-9, the same
    // ranking and selection).
    let args = [
        "select",
        "--data",
        SEED002_FIG3,
        "--target",
        "S1",
        "--method",
        "wgrey",
    ];
    let (v, se) = json(&args);
    assert!(
        se.contains("S1 (run 1) start(s) at 0") && se.contains("interval processing"),
        "{se}"
    );
    assert_eq!(v["scale"], "initial");
    let t = &v["per_target"]["S1"];
    assert_eq!(t["scale_used"], "interval");
    assert_fell_back_for_s1(&t["scale_fallback"], 16);
    let got = numbers(&t["gamma"]);
    assert_eq!(got.len(), 16);
    for (i, (g, w)) in got.iter().zip(S1_INTERVAL_GAMMAS).enumerate() {
        assert!((g - w).abs() <= 1e-9, "T{}: {g} vs {w}", i + 1);
    }
    let mut explicit = args.to_vec();
    explicit.extend(["--scale", "interval"]);
    let (w, se) = json(&explicit);
    assert!(
        !se.contains("start(s) at 0"),
        "no fallback when asked: {se}"
    );
    assert_eq!(w["per_target"]["S1"]["scale_fallback"], Value::Null);
    assert_eq!(t["ranking"], w["per_target"]["S1"]["ranking"]);
    assert_eq!(strings(&t["ranking"]).len(), 16);
    assert_eq!(v["selected"], w["selected"]);
    assert_eq!(
        strings(&v["selected"]),
        ["T3", "T9", "T10", "T11", "T12", "T13"]
    );
}

#[test]
fn grey_with_a_target_starting_at_0_falls_back_to_interval_processing() {
    // The same for grey: the grey coefficients with S1 (1e-12: the same
    // arithmetic), the typical variables and the selection equal those of
    // --scale interval. The inputs start far from 0, so their relative
    // degree keeps initial-value images.
    let inputs = "T1,T2,T3,T4,T5,T6,T7,T8";
    let args = [
        "select",
        "--data",
        SEED002_FIG3,
        "--target",
        "S1",
        "--inputs",
        inputs,
        "--method",
        "grey",
    ];
    let (v, se) = json(&args);
    assert!(se.contains("S1 (run 1) start(s) at 0"), "{se}");
    assert_eq!(v["scale"], "initial");
    assert_eq!(v["scale_used"], "interval");
    assert_fell_back_for_s1(&v["scale_fallback"], 8);
    assert_eq!(v["relative_images"], "initial");
    assert_eq!(v["relative_fallback"], Value::Null);
    let mut explicit = args.to_vec();
    explicit.extend(["--scale", "interval"]);
    let (w, _) = json(&explicit);
    let coef = |j: &Value| -> Vec<f64> {
        j["variables"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x["grey_coefficient"].as_f64().unwrap())
            .collect()
    };
    let (got, want) = (coef(&v), coef(&w));
    assert_eq!(got.len(), 8);
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() <= 1e-12, "{g} vs {w}");
    }
    assert_eq!(v["typical"], w["typical"]);
    assert!(!strings(&v["selected"]).is_empty());
    assert_eq!(v["selected"], w["selected"]);
}

#[test]
fn grey_relative_degree_of_an_input_starting_at_0_falls_back_too() {
    // S2 (also zeroed at the start) as a candidate input: the relative
    // degree between the inputs takes interval images of all of them, and
    // says so.
    let (v, se) = json(&[
        "select",
        "--data",
        SEED002_FIG3,
        "--target",
        "T1",
        "--inputs",
        "T2,T3,S2",
        "--method",
        "grey",
    ]);
    assert!(se.contains("S2 (run 1) start(s) at 0"), "{se}");
    assert_eq!(v["relative_images"], "interval");
    assert_eq!(strings(&v["relative_fallback"]["zero_start"]), ["S2"]);
    assert_eq!(v["scale_used"], "interval");
    let rel = &v["relative"];
    for i in 0..3 {
        let d = rel[i][i].as_f64().unwrap();
        assert!((d - 1.0).abs() <= 1e-12, "diagonal {d}");
    }
}

#[test]
fn runs_repeated_give_the_same_weighted_correlativity() {
    // Differences and processing restart per run, so the same run twice
    // gives the very same gammas (D_max and every mean are unchanged).
    let args = |twice: bool| {
        let mut a = vec!["select", "--data", SEED002_FIG3];
        if twice {
            a.extend(["--data", SEED002_FIG3]);
        }
        a.extend(["--target", "S2", "--method", "wgrey", "--scale", "interval"]);
        json(&a).0
    };
    let (one, two) = (args(false), args(true));
    let (g1, g2) = (
        numbers(&one["per_target"]["S2"]["gamma"]),
        numbers(&two["per_target"]["S2"]["gamma"]),
    );
    for (a, b) in g1.iter().zip(&g2) {
        assert!((a - b).abs() <= 1e-12);
    }
    assert_eq!(two["per_target"]["S2"]["rows"], 52);
}

#[test]
fn missing_cells_are_left_out_and_counted() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = String::from("t_s,T1,T2,T3,y_um\n");
    for k in 0..40 {
        let t = k as f64;
        let (t1, t2, t3) = (
            20.0 + 0.1 * t,
            21.0 + 0.05 * t * t / 40.0,
            22.0 + (t / 5.0).sin(),
        );
        let y = if k == 7 {
            String::new()
        } else {
            format!("{}", 1.0 + 2.0 * (t1 - 20.0) + 0.5 * (t3 - 22.0))
        };
        let t2 = if k == 11 {
            String::new()
        } else {
            t2.to_string()
        };
        s.push_str(&format!("{t},{t1},{t2},{t3},{y}\n"));
    }
    let f = write(dir.path(), "gaps.csv", &s);
    for method in ["grey", "wgrey", "maxtree"] {
        let (v, se) = json(&[
            "select", "--data", &f, "--target", "y_um", "--method", method, "--scale", "interval",
        ]);
        assert!(
            se.contains("2 of 40 rows lack a value of y_um or of an input: left out"),
            "{method}: {se}"
        );
        assert!(!strings(&v["selected"]).is_empty());
    }
}

#[test]
fn text_output_and_errors() {
    let (so, _) = ok(&[
        "select", "--data", FL_THERMAL, "--target", "ch5_um", "--method", "maxtree",
    ]);
    assert!(so.contains("selected: T") && so.contains("lambda"), "{so}");

    // (arguments after `--data FL_THERMAL --target`, what the error says)
    let cases: [(&[&str], &[&str]); 5] = [
        (&["ch1_um,ch2_um", "--method", "grey"], &["one --target"]),
        (
            &["ch9_um", "--method", "wgrey"],
            &["run.csv", "no column \"ch9_um\""],
        ),
        (
            &["ch1_um", "--inputs", "T1,ch1_um", "--method", "maxtree"],
            &["both a --target and an input"],
        ),
        (
            &["ch1_um", "--method", "grey", "--level", "1.5"],
            &["--level"],
        ),
        // Grey clustering at a level no pair reaches: 16 typical variables,
        // too many combinations.
        (
            &["ch1_um", "--method", "grey", "--level", "1"],
            &["more than 12 typical variables"],
        ),
    ];
    for (tail, wants) in cases {
        let mut args = vec!["select", "--data", FL_THERMAL, "--target"];
        args.extend_from_slice(tail);
        let e = fails(&args);
        assert!(wants.iter().all(|w| e.contains(w)), "{e}");
    }
}

/// A target with one value over every run, and (for wgrey, as grey and
/// maxtree already did) an input with one value, are refused by name
/// (grey and maxtree used to fail on a flat target by suggesting scales
/// that divide by zero too; wgrey ranked a flat target's or inputs' equal
/// grades as if they meant something).
#[test]
fn flat_targets_and_inputs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut flat_target = String::from("t_s,T1,T2,dz_um\n");
    let mut flat_input = String::from("t_s,T1,T2,dz_um\n");
    for k in 0..50 {
        let (t1, t2) = (20.0 + 0.1 * f64::from(k), 20.0 + 0.05 * f64::from(k % 9));
        flat_target.push_str(&format!("{k},{t1},{t2},0\n"));
        flat_input.push_str(&format!("{k},{t1},20,{}\n", 0.3 * f64::from(k)));
    }
    let target = write(dir.path(), "flat_target.csv", &flat_target);
    let input = write(dir.path(), "flat_input.csv", &flat_input);
    for method in ["grey", "wgrey", "maxtree"] {
        let e = fails(&[
            "select", "--data", &target, "--target", "dz_um", "--method", method, "--top", "1",
        ]);
        assert_eq!(
            e, "error: dz_um is constant (0) in every run: nothing to rank the inputs by\n",
            "{method}"
        );
    }
    let e = fails(&[
        "select", "--data", &input, "--target", "dz_um", "--method", "wgrey", "--top", "1",
    ]);
    assert_eq!(
        e,
        "error: T2 is constant over the 50 rows used: it cannot be ranked; leave it out with \
         --inputs\n"
    );
}
