//! Host cost of one model update (`ValidModel::step`) per model kind at the
//! sizes the seed papers use, of decoding (and so validating) each model's
//! blob, and of one RTD conversion.
//!
//! Why these: the hub samples at about 1 Hz, so an update has a budget of
//! milliseconds even in soft-float f64 on the Cortex-M4F; what matters is how
//! the kinds compare and that nothing is accidentally quadratic. Decoding is
//! the slow path, run once when a model is flashed: validation finds the
//! roots of every TF's numerator and denominator. The host numbers here are
//! relative; on-chip cycles are measured separately (docs/benchmarks.md).
//!
//! `cargo bench -p model-core --bench update` (about a minute: 2 s of
//! measurement and 50 samples per case).

use criterion::Criterion;
use model_core::arma::Arma;
use model_core::blob::{self, MAX_BLOB_LEN};
use model_core::bp::{Activation, BpNet};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::pcr::{Component, Pcr, PcrOutput};
use model_core::position::PositionTerm;
use model_core::rtd::Rtd;
use model_core::tf::TfEntry;
use model_core::{Channel, Model, ModelState, Name, Params, Reference, ValidModel};
use std::hint::black_box;
use std::time::Duration;

fn hv<T: Clone, const N: usize>(values: &[T]) -> heapless::Vec<T, N> {
    heapless::Vec::from_slice(values).expect("bench data fits the capacity")
}

fn channels(names: &[&str], reference: Reference) -> heapless::Vec<Channel, 24> {
    names
        .iter()
        .map(|n| Channel {
            name: Name::try_from(*n).expect("short name"),
            reference,
        })
        .collect()
}

fn names(names: &[&str]) -> heapless::Vec<Name, 4> {
    names
        .iter()
        .map(|n| Name::try_from(*n).expect("short name"))
        .collect()
}

/// `(1 - p1 q)(1 - p2 q)...`, ascending powers of q.
fn from_poles(poles: &[f64]) -> Vec<f64> {
    let mut c = vec![1.0];
    for p in poles {
        let mut next = vec![0.0; c.len() + 1];
        for (i, v) in c.iter().enumerate() {
            next[i] += v;
            next[i + 1] -= p * v;
        }
        c = next;
    }
    c
}

/// Deterministic weights in (-1, 1): the cost of a forward pass does not
/// depend on the values, only on the sizes.
fn weights(n: usize, salt: f64) -> Vec<f64> {
    (0..n).map(|i| (i as f64 * 0.7 + salt).sin()).collect()
}

/// Seed 004 Table 3's SP1 (denominator with 3 delays, as printed) plus
/// Table 2's ambient TF (its common (1 - q) cancelled at validation).
fn tf_sp1_ambient() -> Model {
    Model {
        inputs: channels(&["T1", "ambient_c"], Reference::First),
        outputs: names(&["dz_um"]),
        dt_s: 1.0,
        params: Params::Tf(hv(&[
            TfEntry {
                output: 0,
                input: 0,
                a: hv(&[-0.0337, 0.0332, 0.0]),
                b: hv(&[1.0, -1.3009, -0.3263, 0.6273]),
            },
            TfEntry {
                output: 0,
                input: 1,
                a: hv(&[-0.0251, 0.0251, 0.0]),
                b: hv(&[1.0, -1.9985, 0.9985]),
            },
        ])),
    }
}

/// Four temperatures, each through a 4/4-order TF (five coefficients in `a`
/// and `b`, thermal time constants from seconds to 1000 samples), into
/// two outputs: a bank larger than any seed 004 prints.
fn tf_bank_4x4() -> Model {
    let poles: [[f64; 4]; 4] = [
        [0.999, 0.99, 0.9, 0.5],
        [0.998, 0.95, 0.8, -0.3],
        [0.9995, 0.97, 0.6, 0.2],
        [0.997, 0.93, 0.85, 0.4],
    ];
    let entries: Vec<TfEntry> = poles
        .iter()
        .enumerate()
        .map(|(i, p)| TfEntry {
            output: u8::from(i % 2 == 1),
            input: i as u8,
            a: hv(&[0.5, -0.3, 0.2, -0.1, 0.05]),
            b: hv(&from_poles(p)),
        })
        .collect();
    Model {
        inputs: channels(&["T1", "T2", "T3", "T4"], Reference::First),
        outputs: names(&["dx_um", "dz_um"]),
        dt_s: 1.0,
        params: Params::Tf(hv(&entries)),
    }
}

/// Seed 002 Eq. 6: four temperatures.
fn linear_seed002() -> Model {
    Model {
        inputs: channels(&["T3", "T4", "T10", "T12"], Reference::Absolute),
        outputs: names(&["x_um"]),
        dt_s: 0.0,
        params: Params::Linear(Linear {
            outputs: hv(&[LinearOutput {
                output: 0,
                intercept: -0.2565,
                coef: hv(&[
                    Coef {
                        channel: 0,
                        value: 0.0189,
                    },
                    Coef {
                        channel: 1,
                        value: -0.0124,
                    },
                    Coef {
                        channel: 2,
                        value: 0.0082,
                    },
                    Coef {
                        channel: 3,
                        value: -0.0074,
                    },
                ]),
                position: None,
            }]),
        }),
    }
}

/// Seed 003 Eq. 13-14 (five temperatures, one component); with `position`,
/// Eq. 16's fifth-order positioning-error polynomial along Y.
fn pcr_seed003(position: bool) -> Model {
    let mut inputs = channels(&["T1", "T2", "T5", "T7", "T11"], Reference::Absolute);
    let position = position.then(|| {
        inputs
            .push(Channel {
                name: Name::try_from("y_mm").expect("short name"),
                reference: Reference::Absolute,
            })
            .expect("room");
        PositionTerm {
            channel: 5,
            poly: hv(&[-1.6437, 0.0, -0.0144, 1.5173e-4, -5.5207e-7, 6.8499e-10]),
            k0: -0.0171,
        }
    });
    Model {
        inputs,
        outputs: names(&["k"]),
        dt_s: 0.0,
        params: Params::Pcr(Pcr {
            outputs: hv(&[PcrOutput {
                output: 0,
                inputs: hv(&[0, 1, 2, 3, 4]),
                components: hv(&[Component {
                    intercept: -50.6062,
                    weights: hv(&[0.1631, 0.4902, 0.2512, 0.6614, 1.1666]),
                }]),
                intercept: -0.3243,
                beta: hv(&[0.0396]),
                position,
            }]),
        }),
    }
}

/// An m-n-3 tansig/purelin net (seed 000's is 4-11-3: four temperatures,
/// elongation and two tilt angles).
fn bp(m: usize, n: usize) -> Model {
    let inputs: Vec<String> = (1..=m).map(|i| format!("T{i}")).collect();
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    Model {
        inputs: channels(&inputs, Reference::Absolute),
        outputs: names(&["dz_um", "tilt_x_urad", "tilt_y_urad"]),
        dt_s: 0.0,
        params: Params::Bp(BpNet {
            inputs: (0..m as u8).collect(),
            outputs: hv(&[0, 1, 2]),
            hidden_activation: Activation::Tansig,
            output_activation: Activation::Purelin,
            w1: hv(&weights(n * m, 0.1)),
            b1: hv(&weights(n, 0.2)),
            w2: hv(&weights(3 * n, 0.3)),
            b2: hv(&weights(3, 0.4)),
            x_min: hv(&vec![18.0; m]),
            x_max: hv(&vec![45.0; m]),
            y_min: hv(&[-40.0, -20.0, -20.0]),
            y_max: hv(&[5.0, 20.0, 20.0]),
        }),
    }
}

/// ARMA(2, 1) on the once-differenced series (seed 001's form).
fn arma_2_1_d1() -> Model {
    Model {
        inputs: channels(&["dz_um"], Reference::Absolute),
        outputs: names(&["dz_um"]),
        dt_s: 60.0,
        params: Params::Arma(Arma {
            channel: 0,
            output: 0,
            mean: -12.5,
            std: 6.25,
            diff: 1,
            constant: 0.01,
            phi: hv(&[0.6, -0.2]),
            theta: hv(&[0.3]),
        }),
    }
}

fn cases() -> Vec<(&'static str, ValidModel)> {
    [
        ("tf_sp1_ambient_2x", tf_sp1_ambient()),
        ("tf_bank_4x_order4", tf_bank_4x4()),
        ("linear_4in", linear_seed002()),
        ("pcr_5in_1pc", pcr_seed003(false)),
        ("pcr_5in_1pc_position", pcr_seed003(true)),
        ("bp_4x11x3", bp(4, 11)),
        ("bp_16x24x3", bp(16, 24)),
        ("arma_2_1_d1", arma_2_1_d1()),
    ]
    .into_iter()
    .map(|(label, m)| (label, m.validate().expect("bench model is valid")))
    .collect()
}

/// Raw inputs of a warm machine: temperatures in C (and a position in mm).
fn inputs(vm: &ValidModel) -> Vec<f64> {
    (0..vm.inputs().len())
        .map(|i| 24.0 + 0.25 * i as f64)
        .collect()
}

fn step(c: &mut Criterion) {
    let mut g = c.benchmark_group("step");
    for (label, vm) in cases() {
        let x = inputs(&vm);
        let mut state = ModelState::new();
        let mut out = [0.0; 4];
        // The first sample sets references and steady-state histories; time
        // the updates that follow it.
        vm.step(&mut state, &x, &mut out).expect("finite inputs");
        g.bench_function(label, |b| {
            b.iter(|| {
                vm.step(&mut state, black_box(&x), black_box(&mut out))
                    .expect("finite inputs")
            })
        });
    }
    g.finish();
}

fn decode(c: &mut Criterion) {
    let mut g = c.benchmark_group("decode");
    for (label, vm) in cases() {
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = blob::encode(&vm, &mut buf).expect("encodes");
        let bytes = &buf[..n];
        g.bench_function(format!("{label} ({n} B)"), |b| {
            b.iter(|| model_core::decode(black_box(bytes)).expect("valid blob"))
        });
    }
    g.finish();
}

fn rtd(c: &mut Criterion) {
    let mut g = c.benchmark_group("rtd");
    // R(+100 C) = 138.5055 ohm: closed-form branch. R(-50 C) = 80.3063 ohm:
    // Newton on the full CVD equation (the C term applies below 0 C).
    for (label, r_ohm) in [("pt100_above_0c", 138.5055), ("pt100_below_0c", 80.3063)] {
        g.bench_function(label, |b| {
            b.iter(|| {
                Rtd::PT100
                    .temperature_c(black_box(r_ohm))
                    .expect("in range")
            })
        });
    }
    g.finish();
}

/// What `criterion_group!`/`criterion_main!` would generate, written out so
/// that no undocumented public function trips the workspace's `missing_docs`.
fn main() {
    let mut c = Criterion::default()
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500))
        .sample_size(50)
        .configure_from_args();
    step(&mut c);
    decode(&mut c);
    rtd(&mut c);
    c.final_summary();
}
