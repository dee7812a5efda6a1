//! Seed 002 (hobbing machine, weighted grey correlativity + least squares)
//! and seed 003 (feed-axis positioning error, PCR): the published equations
//! written as specs, run through blob and `ValidModel::step`, against values
//! worked independently.

use model_core::{ModelState, ValidModel};
use thermcomp_tests::isclose;

fn through_blob(name: &str, spec: &str) -> ValidModel {
    let model = host_tools::data::spec::parse(name, spec).expect("spec builds");
    let blob = model_core::blob::encode_to_vec(&model).expect("encodes");
    model_core::decode(&blob).expect("decodes")
}

fn step(model: &ValidModel, x: &[f64]) -> f64 {
    let mut out = [0.0];
    model
        .step(&mut ModelState::new(), x, &mut out)
        .expect("finite inputs");
    out[0]
}

/// Seed 002 Eq. 6 evaluated on the 26 rows of the paper's Figure 3 table
/// (tests/data/seed002_fig3.csv, transcribed from the seed, times as seconds
/// after 9:03:00).
#[test]
fn seed002_eq6_on_figure3_rows() {
    let model = through_blob(
        "eq6.toml",
        r#"
kind = "linear"
[[linear]]
output = "x_um"
intercept = -0.2565
coef = { T3 = 0.0189, T4 = -0.0124, T10 = 0.0082, T12 = -0.0074 }
"#,
    );
    // x_m per row in exact decimal arithmetic (Python 3.11 `decimal`, the
    // products of 4-digit coefficients and 2-digit temperatures are exact).
    const EXPECTED: [f64; 26] = [
        -0.202887, -0.201939, -0.201416, -0.199810, -0.195859, -0.194599, -0.193798, -0.195355,
        -0.195483, -0.195559, -0.195434, -0.197701, -0.198631, -0.201465, -0.200545, -0.201933,
        -0.202480, -0.204885, -0.203929, -0.207505, -0.208249, -0.208958, -0.210608, -0.214298,
        -0.215801, -0.216670,
    ];
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/seed002_fig3.csv");
    let run = host_tools::data::runfile::RunFile::read(path.as_ref(), &Default::default()).unwrap();
    assert_eq!(run.len(), EXPECTED.len());
    let cols: Vec<host_tools::data::cells::Cells> = ["T3", "T4", "T10", "T12"]
        .iter()
        .map(|c| run.column(c).unwrap())
        .collect();
    for (row, expected) in EXPECTED.iter().enumerate() {
        let x: Vec<f64> = cols.iter().map(|c| c.get(row).unwrap()).collect();
        let got = step(&model, &x);
        // f64 rounding of five products of size ~0.3: well under 1e-12.
        assert!(
            (got - expected).abs() < 1e-12,
            "row {row}: {got} vs {expected}"
        );
    }
}

const PCR_EQ13_14: &str = r#"
kind = "pcr"
[[pcr]]
output = "k"
inputs = ["T1", "T2", "T5", "T7", "T11"]
components = [{ intercept = -50.6062, weights = [0.1631, 0.4902, 0.2512, 0.6614, 1.1666] }]
intercept = -0.3243
beta = [0.0396]
"#;

/// Eq. 13 (kp = -0.3243 + 0.0396 C1) with Eq. 14 (C1 from the raw
/// temperatures) collapses to Eq. 15 within the rounding of the printed
/// coefficients.
#[test]
fn seed003_eq13_and_eq14_give_eq15() {
    let model = through_blob("pcr.toml", PCR_EQ13_14);
    let model_core::Params::Pcr(pcr) = &model.model().params else {
        panic!("pcr model expected")
    };
    let (d0, d) = pcr.equivalent_linear(&pcr.outputs[0]);
    // Eq. 15: kp = 0.0065 T1 + 0.0194 T2 + 0.0099 T5 + 0.0262 T7 + 0.0462 T11 - 2.3283
    let eq15 = [0.0065, 0.0194, 0.0099, 0.0262, 0.0462];
    let w = [0.1631, 0.4902, 0.2512, 0.6614, 1.1666];
    let (beta, half) = (0.0396_f64, 0.5e-4);
    for i in 0..5 {
        // Each printed number carries up to half a unit in its last (4th)
        // decimal: |d(beta w)| <= half |w| + half |beta| + half^2, plus Eq. 15's own rounding.
        let tol = half * w[i] + half * beta + half * half + half;
        assert!(
            (d[i] - eq15[i]).abs() <= tol,
            "T coef {i}: {} vs {}",
            d[i],
            eq15[i]
        );
    }
    // Constant: -0.3243 + 0.0396 * -50.6062, same rounding argument.
    let tol0 = half + half * 50.6062 + half * beta + half * half + half;
    assert!((d0 - -2.3283).abs() <= tol0, "constant {d0}");
    // The run-time path gives the collapsed form's value.
    let t = [22.1, 24.3, 26.0, 21.7, 23.2];
    let direct = d0 + d.iter().zip(&t).map(|(a, b)| a * b).sum::<f64>();
    assert!(isclose(step(&model, &t), direct, 1e-12, 1e-12));
}

/// Eq. 16: the Y-axis positioning error is poly(y) + (kp(T) - k0) y. Its
/// printed slope constant -2.3112 is Eq. 15's -2.3283 minus k0, so k0 = -0.0171.
#[test]
fn seed003_eq16_positioning_error() {
    let spec = PCR_EQ13_14.replace(
        "beta = [0.0396]",
        "beta = [0.0396]\nposition = { input = \"y_mm\", poly = [-1.6437, 0.0, -0.0144, 1.5173e-4, -5.5207e-7, 6.8499e-10], k0 = -0.0171 }",
    );
    let model = through_blob("eq16.toml", &spec);
    assert_eq!(
        model.inputs().len(),
        6,
        "five temperatures and the position"
    );
    let t = [22.1, 24.3, 26.0, 21.7, 23.2];
    for y in [0.0, 10.0, 140.0, 280.0] {
        let mut x = t.to_vec();
        x.push(y);
        let got = step(&model, &x);
        // Eq. 16 as printed, with Eq. 16's own (inconsistently rounded)
        // slope coefficients 0.0461 T11 and -2.3112.
        let slope =
            0.0065 * t[0] + 0.0194 * t[1] + 0.0099 * t[2] + 0.0262 * t[3] + 0.0461 * t[4] - 2.3112;
        let printed = 6.8499e-10 * y.powi(5) - 5.5207e-7 * y.powi(4) + 1.5173e-4 * y.powi(3)
            - 0.0144 * y * y
            + slope * y
            - 1.6437;
        // The printed slope coefficients differ from the exact collapse by up
        // to 1.1e-4 each (0.0461 vs 0.046197 for T11): sum of |T| * 1.2e-4
        // plus the constant's rounding, times |y|.
        let tol = (t.iter().sum::<f64>() * 1.2e-4 + 1.2e-4) * y + 1e-9;
        assert!(
            (got - printed).abs() <= tol,
            "y {y}: {got} vs {printed} (tol {tol})"
        );
    }
}
