//! `fit --report DIR` and `eval --report DIR`: the page holds a chart per
//! output and run (and the CV table of an auto fit), its figures are the
//! command's own, and it never overwrites an input.

mod common;

use common::{fails_one_line, ok, ok_json, p};
use serde_json::Value;
use std::path::Path;

/// `fit --model auto` with the filter bank alone (fast; the families are
/// not what the page is about).
const FIT_AUTO: [&str; 5] = ["fit", "--model", "auto", "--auto-families", "ridge"];

/// An 8 h twin run at 40 s (`simulate`, profile `steps`, `seed`).
fn twin_run(dir: &Path, name: &str, seed: &str) -> String {
    let out = dir.join(name);
    ok(&[
        "simulate",
        "--out",
        p(&out),
        "--hours",
        "8",
        "--dt-s",
        "40",
        "--profile",
        "steps",
        "--seed",
        seed,
    ]);
    p(&out).to_string()
}

/// The page's text, and its inline charts counted.
fn page(dir: &Path) -> (String, usize) {
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let charts = html.matches("<svg ").count();
    (html, charts)
}

/// The JSON shown at the end of the page.
fn page_json(html: &str) -> Value {
    let pre = html.rsplit("<pre>").next().unwrap();
    let pre = pre.split("</pre>").next().unwrap();
    let text = pre
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    serde_json::from_str(&text).unwrap()
}

/// The held-out coverage, %, the page gives for `output` ("{output}: the
/// band covers .. rows with both values; X % of the N held-out rows.").
fn held_out_pct(html: &str, output: &str) -> f64 {
    let para = html
        .split("<p>")
        .find(|p| p.starts_with(&format!("{output}: the band covers")))
        .unwrap_or_else(|| panic!("no coverage line for {output}"));
    let tail = para.split("; ").nth(1).unwrap_or_else(|| panic!("{para}"));
    tail.split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap_or_else(|e| panic!("{e}: {para}"))
}

#[test]
fn an_auto_fit_report_charts_every_output_and_says_its_own_figures() {
    let dir = tempfile::tempdir().unwrap();
    let data = twin_run(dir.path(), "r.csv", "3");
    let model = dir.path().join("m.bin");
    let rep = dir.path().join("rep");
    let json = ok_json(
        &[
            &FIT_AUTO[..],
            &[
                "--data",
                &data,
                "--target",
                "dx_um,dz_um",
                "--holdout-from-s",
                "21600",
                "--out",
                p(&model),
                "--report",
                p(&rep),
                "--json",
            ],
        ]
        .concat(),
    );
    let (html, charts) = page(&rep);
    // One CV chart per target, then per output: measured/predicted and the
    // residual, on the one run.
    assert_eq!(charts, 2 + 2 * 2, "charts");
    assert_eq!(page_json(&html), json, "the page's JSON is fit --json's");
    assert!(html.contains("dz_um: CV error of the best"), "CV chart");
    // Every member of the model has its bar (marked " *"), ranked in the
    // best 15 or not.
    let members: usize = json["details"]["targets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            t["cv_table"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|r| r["chosen"] == true && r["cv_geo_rmse"].is_f64())
                .count()
        })
        .sum();
    assert!(members > 0);
    assert_eq!(html.matches(" *</text>").count(), members, "members' bars");
    // The fit's table as it prints: dz_um's held-out rmse to 3 decimals.
    let rmse = json["targets"]["dz_um"]["holdout"]["rmse_um"]
        .as_f64()
        .unwrap();
    let row = html
        .lines()
        .flat_map(|l| l.split('\n'))
        .find(|l| l.starts_with("dz_um") && l.contains("held-out"))
        .unwrap_or_else(|| panic!("no held-out row for dz_um"));
    assert!(row.contains(&format!("{rmse:.3}")), "{row} vs {rmse}");
    // The held-out coverage the page states is the one predict --interval's
    // band gives on the rows at or after 21600 s (the same runner, so to the
    // printed 0.1 %).
    let pred = dir.path().join("p.csv");
    ok(&[
        "predict",
        "--model",
        p(&model),
        "--data",
        &data,
        "--interval",
        "--out",
        p(&pred),
    ]);
    let text = std::fs::read_to_string(&pred).unwrap();
    let measured = std::fs::read_to_string(&data).unwrap();
    let index = |csv: &str, name: &str| {
        let head = csv.lines().next().unwrap();
        head.split(',').position(|c| c == name).unwrap()
    };
    let col = index(&measured, "dz_um");
    let (lo_col, hi_col) = (index(&text, "dz_um_lo95"), index(&text, "dz_um_hi95"));
    let (mut n, mut inside) = (0, 0);
    for (pl, ml) in text.lines().skip(1).zip(measured.lines().skip(1)) {
        let pv: Vec<f64> = pl.split(',').map(|c| c.parse().unwrap()).collect();
        let y: f64 = ml.split(',').nth(col).unwrap().parse().unwrap();
        if pv[0] >= 21600.0 {
            n += 1;
            let (lo, hi) = (pv[lo_col], pv[hi_col]);
            inside += usize::from(lo <= y && y <= hi);
        }
    }
    let expect = 100.0 * inside as f64 / n as f64;
    let said = held_out_pct(&html, "dz_um");
    assert!(
        (said - expect).abs() <= 0.051,
        "page {said} %, predict {expect} %"
    );
}

#[test]
fn an_eval_report_charts_each_run_and_never_overwrites_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let cal = twin_run(dir.path(), "cal.csv", "4");
    let other = twin_run(dir.path(), "other.csv", "5");
    let model = dir.path().join("m.bin");
    ok(&[
        &FIT_AUTO[..],
        &["--data", &cal, "--target", "dz_um", "--out", p(&model)],
    ]
    .concat());
    let rep = dir.path().join("rep");
    let (_, err) = ok(&[
        "eval",
        "--model",
        p(&model),
        "--data",
        &cal,
        "--data",
        &other,
        "--report",
        p(&rep),
    ]);
    assert!(err.contains("index.html"), "says where: {err}");
    let (html, charts) = page(&rep);
    assert_eq!(charts, 2 * 2, "two charts per run");
    assert!(html.contains("other.csv (evaluated)"), "runs named");
    // A report page that would replace a run is refused before anything runs.
    let clash = dir.path().join("clash");
    std::fs::create_dir(&clash).unwrap();
    let run_there = clash.join("index.html");
    std::fs::copy(&cal, &run_there).unwrap();
    // The model itself as the page: eval reads it too.
    let clash_model = dir.path().join("clash_model");
    std::fs::create_dir(&clash_model).unwrap();
    let model_there = clash_model.join("index.html");
    std::fs::copy(&model, &model_there).unwrap();
    let x_bin = dir.path().join("x.bin");
    let cases: [(Vec<&str>, &Path); 3] = [
        (
            vec![
                "eval",
                "--model",
                p(&model),
                "--data",
                p(&run_there),
                "--report",
                p(&clash),
            ],
            &run_there,
        ),
        (
            vec![
                "eval",
                "--model",
                p(&model_there),
                "--data",
                &cal,
                "--report",
                p(&clash_model),
            ],
            &model_there,
        ),
        (
            vec![
                "fit",
                "--model",
                "mlr",
                "--data",
                p(&run_there),
                "--target",
                "dz_um",
                "--out",
                p(&x_bin),
                "--report",
                p(&clash),
            ],
            &run_there,
        ),
    ];
    for (argv, input) in cases {
        let kept = std::fs::read(input).unwrap();
        let e = fails_one_line(&argv);
        assert!(e.contains("--report"), "{argv:?}: {e}");
        assert_eq!(
            std::fs::read(input).unwrap(),
            kept,
            "{argv:?}: input untouched"
        );
    }
    // A --report that is a file, not a folder, is refused before the fit.
    let e = fails_one_line(&[
        "fit",
        "--model",
        "mlr",
        "--data",
        &cal,
        "--target",
        "dz_um",
        "--out",
        p(&x_bin),
        "--report",
        &other,
    ]);
    assert!(e.contains("not a folder"), "{e}");
    assert!(!x_bin.exists(), "nothing written");
}
