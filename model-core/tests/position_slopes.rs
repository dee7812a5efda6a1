//! The thermal slope of positional outputs (seed 003 Eq. 16), what the hub
//! sends a CNC's position-dependent temperature compensation: the model's
//! own output must equal the geometric polynomial plus slope x position at
//! every position, so the CNC reproduces the model exactly.

mod common;

use common::{arma_2_1_d1, bp_3_4_2, linear_seed002, pcr_seed003, tf_bank_4x4};
use model_core::linear::Linear;
use model_core::position::PositionTerm;
use model_core::{ModelState, Params, ValidModel};

/// Seed 003's published temperatures for its Eq. 16 check (deg C), warm.
const TEMPS: [f64; 5] = [24.1, 25.3, 23.8, 26.0, 27.4];

fn step_at(model: &ValidModel, p_mm: f64) -> (f64, f64) {
    let mut state = ModelState::new();
    let mut inputs = TEMPS.to_vec();
    inputs.push(p_mm);
    let mut out = [0.0; 4];
    model.step(&mut state, &inputs, &mut out).unwrap();
    let mut slopes = [f64::NAN; 4];
    model.thermal_slopes(&state, &inputs, &mut slopes).unwrap();
    (out[0], slopes[0])
}

fn position_term(model: &ValidModel) -> PositionTerm {
    match &model.model().params {
        Params::Pcr(p) => p.outputs[0].position.clone().unwrap(),
        _ => unreachable!("a PCR model"),
    }
}

/// At every position the output is `poly(P) + slope P`, the slope does not
/// depend on P, and it equals seed 003's `k(T) - k0` by hand:
/// `k = -0.3243 + 0.0396 C`, `C = -50.6062 + w . T`, `k0 = -0.0171`.
/// Tolerance 1e-12 um: the same f64 arithmetic in another order.
#[test]
fn pcr_positional_output_is_poly_plus_slope_times_position() {
    let model = pcr_seed003(true).validate().unwrap();
    assert_eq!(model.positional_outputs(), 0b1);
    assert_eq!(model.position_inputs(), 1 << 5);
    let pos = position_term(&model);
    let w = [0.1631, 0.4902, 0.2512, 0.6614, 1.1666];
    let c = -50.6062 + w.iter().zip(TEMPS).map(|(w, t)| w * t).sum::<f64>();
    let by_hand = -0.3243 + 0.0396 * c - -0.0171;
    let (_, slope0) = step_at(&model, 0.0);
    assert!((slope0 - by_hand).abs() < 1e-12, "{slope0} vs {by_hand}");
    for p in [0.0, 55.0, 300.0, 612.5] {
        let (y, slope) = step_at(&model, p);
        assert_eq!(slope, slope0, "slope independent of P at {p} mm");
        assert!(
            (y - (pos.error(pos.k0, p) + slope * p)).abs() < 1e-12,
            "P = {p}"
        );
    }
}

/// A linear output with a position term gives the same split; a model
/// without one has no positional output, and buffer entries past the
/// model's outputs keep what they held.
#[test]
fn linear_positional_output_and_plain_outputs() {
    assert_eq!(linear_seed002().validate().unwrap().positional_outputs(), 0);
    let mut model = linear_seed002();
    let n_in = model.inputs.len();
    model
        .inputs
        .push(model_core::Channel {
            name: model_core::Name::try_from("x_mm").unwrap(),
            reference: model_core::Reference::Absolute,
        })
        .unwrap();
    let Params::Linear(Linear { outputs }) = &mut model.params else {
        unreachable!("a linear model")
    };
    outputs[0].position = Some(PositionTerm {
        channel: n_in as u8,
        poly: heapless::Vec::from_slice(&[0.5, 0.01]).unwrap(),
        k0: 0.002,
    });
    let n_out = outputs.len();
    let model = model.validate().unwrap();
    assert_eq!(model.positional_outputs(), 0b1);
    assert_eq!(model.position_inputs(), 1 << n_in);
    let mut state = ModelState::new();
    let mut inputs: Vec<f64> = (0..n_in).map(|i| 22.0 + i as f64).collect();
    inputs.push(250.0);
    let mut out = [0.0; 4];
    model.step(&mut state, &inputs, &mut out).unwrap();
    let mut slopes = [-7.0; 4];
    model.thermal_slopes(&state, &inputs, &mut slopes).unwrap();
    let geometric = 0.5 + 0.01 * 250.0;
    assert!((out[0] - (geometric + slopes[0] * 250.0)).abs() < 1e-12);
    assert_eq!(n_out, 1, "seed 002's model has one output");
    assert_eq!(
        &slopes[1..],
        &[-7.0; 3],
        "no slope written past the outputs"
    );
}

/// Inputs that `step` refuses are refused here too, writing nothing.
#[test]
fn refused_inputs_write_no_slope() {
    let model = pcr_seed003(true).validate().unwrap();
    let state = ModelState::new();
    let mut slopes = [1.5; 4];
    let mut bad = TEMPS.to_vec();
    bad.push(f64::NAN);
    assert!(model.thermal_slopes(&state, &bad, &mut slopes).is_err());
    assert!(model.thermal_slopes(&state, &TEMPS, &mut slopes).is_err());
    assert_eq!(slopes, [1.5; 4]);
}

/// Which inputs each output reads: a linear output its coefficients' (and
/// position's) channels only; a PCR output every component input; a TF
/// output the inputs of its entries; a BP output every net input; an ARMA
/// forecast its one series.
#[test]
fn output_inputs_name_what_each_output_reads() {
    let pcr = pcr_seed003(true).validate().unwrap();
    assert_eq!(pcr.output_inputs(0), 0b11_1111, "5 temperatures + y");
    assert_eq!(pcr.output_inputs(1), 0, "no such output");
    let lin = linear_seed002().validate().unwrap();
    let Params::Linear(l) = &lin.model().params else {
        unreachable!("a linear model")
    };
    let want = l.outputs[0]
        .coef
        .iter()
        .fold(0u32, |m, c| m | 1 << c.channel);
    assert_ne!(want, 0);
    assert_eq!(lin.output_inputs(0), want);
    // tf_bank_4x4: entries T1 -> dx, T2 -> dz, T3 -> dx, T4 -> dz.
    let tf = tf_bank_4x4().validate().unwrap();
    assert_eq!((tf.output_inputs(0), tf.output_inputs(1)), (0b0101, 0b1010));
    let bp = bp_3_4_2().validate().unwrap();
    assert_eq!((bp.output_inputs(0), bp.output_inputs(1)), (0b111, 0b111));
    let arma = arma_2_1_d1().validate().unwrap();
    assert_eq!(arma.output_inputs(0), 0b1);
}
