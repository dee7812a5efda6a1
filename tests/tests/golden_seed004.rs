//! Seed 004 (transfer-function models per spindle unit), Tables 2 and 3.
//!
//! 1. Steady-state gains of eps_SP1, eps_SP2, eps_SP3 and eps_amb, from the
//!    printed coefficients and from a simulated step.
//! 2. The firmware path (spec -> blob -> decode -> `ValidModel::step`, f64,
//!    unit-circle factors cancelled) tracks the printed Eq. 1 run as an f64
//!    reference within 0.01 um at every sample of a 24 h random-walk
//!    temperature at 1 s, for every TF; and the f32 direct form, which the
//!    firmware does not use, is measured to show why.

use model_core::{ModelState, ValidModel};
use thermcomp_tests::{direct_form, isclose, random_walk, Rng};

struct PrintedTf {
    name: &'static str,
    a: &'static [f64],
    b: &'static [f64],
    /// sum(a) / sum(b) worked by hand from the printed digits (after
    /// cancelling the common (1 - q) of eps_amb: -0.0251 / (1 - 0.9985)).
    gain_um_per_k: f64,
}

const TFS: [PrintedTf; 4] = [
    PrintedTf {
        name: "SP1",
        a: &[-0.0337, 0.0332, 0.0],
        b: &[1.0, -1.3009, -0.3263, 0.6273],
        gain_um_per_k: -0.0005 / 0.0001,
    },
    PrintedTf {
        name: "SP2",
        a: &[16.0005, -15.9975, 0.0],
        b: &[1.0, -0.99983],
        gain_um_per_k: 0.0030 / 0.00017,
    },
    PrintedTf {
        name: "SP3",
        a: &[4.30702, -4.28923, 0.0],
        b: &[1.0, -0.9984],
        gain_um_per_k: 0.01779 / 0.0016,
    },
    PrintedTf {
        name: "ambient",
        a: &[-0.0251, 0.0251, 0.0],
        b: &[1.0, -1.9985, 0.9985],
        gain_um_per_k: -0.0251 / 0.0015,
    },
];

fn list(v: &[f64]) -> String {
    let s: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
    s.join(", ")
}

/// The TF as a user writes it, through the whole host path to a blob and back.
fn flashed(tf: &PrintedTf) -> ValidModel {
    let spec = format!(
        "kind = \"tf\"\ndt_s = 1.0\n[[tf]]\noutput = \"dz_um\"\ninput = \"T\"\nreference = \"first\"\na = [{}]\nb = [{}]\n",
        list(tf.a),
        list(tf.b)
    );
    let model = host_tools::data::spec::parse(tf.name, &spec).expect("printed TF builds");
    let blob = model_core::blob::encode_to_vec(&model).expect("encodes");
    model_core::decode(&blob).expect("decodes")
}

fn run(model: &ValidModel, temps: &[f64]) -> Vec<f64> {
    let mut state = ModelState::new();
    let mut out = [0.0];
    temps
        .iter()
        .map(|t| {
            model
                .step(&mut state, &[*t], &mut out)
                .expect("finite input");
            out[0]
        })
        .collect()
}

#[test]
fn steady_state_gains_match_the_printed_coefficients() {
    for tf in &TFS {
        let model = flashed(tf);
        let gain = model.realised_tfs()[0].dc_gain();
        // 1e-9 relative: the sums cancel four significant digits (SP1's
        // denominator 1e-4 from terms of order 1), leaving ~1e-12 of f64 noise.
        assert!(
            isclose(gain, tf.gain_um_per_k, 1e-9, 0.0),
            "{}: gain {gain} vs {}",
            tf.name,
            tf.gain_um_per_k
        );
        // A 1 K step held for 200,000 s (> 30 time constants of the slowest
        // pole, SP2's 0.99983: tau = 5,900 s) settles on the gain to 1e-9 um.
        let mut temps = vec![20.0; 200_000];
        temps[0] = 19.0;
        let y = run(&model, &temps);
        let last = *y.last().unwrap();
        assert!(
            (last - tf.gain_um_per_k).abs() < 1e-6,
            "{}: step settles at {last}, gain {}",
            tf.name,
            tf.gain_um_per_k
        );
    }
}

#[test]
fn firmware_path_tracks_f64_reference_for_24_h() {
    const N: usize = 24 * 3600;
    const BUDGET_UM: f64 = 0.01;
    let mut worst_f32 = Vec::new();
    for (i, tf) in TFS.iter().enumerate() {
        let mut rng = Rng::new(0x5EED_0004 + i as u64);
        // Bearing/ambient-like random walk: 0.02 K per sqrt(s) (about 6 K over
        // a day), kept within 10..60 C.
        let temps = random_walk(&mut rng, N, 25.0, 0.02, 10.0, 60.0);
        let du: Vec<f64> = temps.iter().map(|t| t - temps[0]).collect();
        let firmware = run(&flashed(tf), &temps);
        let reference = direct_form::<f64>(tf.a, tf.b, &du);
        let as_f32 = direct_form::<f32>(tf.a, tf.b, &du);
        let max_err = |y: &[f64]| {
            y.iter()
                .zip(&reference)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0_f64, f64::max)
        };
        let (err_fw, err_f32) = (max_err(&firmware), max_err(&as_f32));
        let peak = reference.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        eprintln!(
            "{:8} peak |y| {peak:9.3} um   firmware path max |err| {err_fw:.3e} um   f32 direct form {err_f32:.3e} um",
            tf.name
        );
        assert!(
            err_fw < BUDGET_UM,
            "{}: firmware path off by {err_fw} um",
            tf.name
        );
        worst_f32.push((tf.name, err_f32));
    }
    // The documented reason for f64: the f32 direct form breaks the budget
    // for the ill-conditioned published TFs. If this ever stops holding, the
    // precision choice in docs/models.md must be revisited.
    assert!(
        worst_f32.iter().any(|(_, e)| *e > BUDGET_UM),
        "f32 would have been enough: {worst_f32:?}"
    );
}
