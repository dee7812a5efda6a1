//! Example models shared by the blob tests (`tests/blob_garbage.rs`) and the
//! update bench (`benches/update.rs`), built from model-core types directly
//! (no spec reader), with published coefficients where a seed paper prints
//! them (docs/models.md lists the kinds and their sources):
//!
//! | fixture | what | source |
//! |---|---|---|
//! | [`tf_sp1_ambient`] | TF bank: SP1 (3rd-order denominator) + ambient | seed 004 Eq. 2, Tables 3 and 2 |
//! | [`tf_sp2_ambient`] | TF bank: SP2 (1st order) + ambient | seed 004 Eq. 2, Tables 3 and 2 |
//! | [`tf_bank_4x4`] | four 4/4-order TFs into two outputs | made up, larger than seed 004 |
//! | [`linear_seed002`] | linear regression on four temperatures | seed 002 Eq. 6 |
//! | [`pcr_seed003`] | PCR, one component of five temperatures, optional Y position term | seed 003 Eq. 13-14, 16 |
//! | [`bp`] | m-n-3 tansig/purelin net, deterministic weights | sizes of seed 000 (4-11-3) |
//! | [`bp_3_4_2`] | 3-4-2 tansig/purelin net, made-up weights | MATLAB `feedforwardnet` form (seeds 000, 003) |
//! | [`arma_2_1_d1`] | ARMA(2, 1) on the once-differenced series | seed 001's form |
//! | [`fbank_3x2`] | filter bank: raw, filtered and squared features of three inputs into two outputs, with or without bounds | made up, fbank form |
//! | [`fbank_wide`] | filter bank of `n_in` inputs x 4 features (taus 0, 10 min, 1 h, 4 h) into one output | made up |
//! | [`fbank_sized`] | filter bank of `n_in` inputs x the given time constants into the given outputs | made up; 32 x 8 x 4 is the largest model-core takes |
//!
//! The tests use the SP2 TF and the 3-4-2 net, the bench the SP1 TF, the
//! 4/4 bank and the m-n-3 nets; the rest serve both.

// Each side uses only some of the fixtures.
#![allow(dead_code)]

use model_core::arma::Arma;
use model_core::bp::{Activation, BpNet};
use model_core::fbank::{FbOutput, Feature, FilterBank};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::model::{MAX_CHANNELS, MAX_OUTPUTS};
use model_core::pcr::{Component, Pcr, PcrOutput};
use model_core::position::PositionTerm;
use model_core::tf::TfEntry;
use model_core::{Bounds, Channel, Model, Name, Params, Reference, Span};

// ---------------------------------------------------------------------------
// Builders
// ---------------------------------------------------------------------------

/// A `heapless::Vec` holding `values`; panics if they do not fit.
pub fn hv<T: Clone, const N: usize>(values: &[T]) -> heapless::Vec<T, N> {
    heapless::Vec::from_slice(values).expect("fixture data fits the capacity")
}

/// A channel or output name; panics if it is too long.
pub fn name(s: &str) -> Name {
    Name::try_from(s).expect("short name")
}

/// One input channel.
pub fn chan(s: &str, reference: Reference) -> Channel {
    Channel {
        name: name(s),
        reference,
    }
}

/// Input channels, all with the same reference.
pub fn channels(names: &[&str], reference: Reference) -> heapless::Vec<Channel, MAX_CHANNELS> {
    names.iter().map(|n| chan(n, reference)).collect()
}

/// Output names.
pub fn outputs(names: &[&str]) -> heapless::Vec<Name, MAX_OUTPUTS> {
    names.iter().map(|n| name(n)).collect()
}

/// `(1 - r1 q)(1 - r2 q)...` for real roots `rs`, ascending powers of q.
pub fn from_roots(rs: &[f64]) -> Vec<f64> {
    let mut p = vec![1.0];
    for r in rs {
        let mut next = vec![0.0; p.len() + 1];
        for (i, c) in p.iter().enumerate() {
            next[i] += c;
            next[i + 1] -= r * c;
        }
        p = next;
    }
    p
}

/// Deterministic weights in (-1, 1): the cost of a forward pass does not
/// depend on the values, only on the sizes.
pub fn weights(n: usize, salt: f64) -> Vec<f64> {
    (0..n).map(|i| (i as f64 * 0.7 + salt).sin()).collect()
}

// ---------------------------------------------------------------------------
// Transfer-function banks (seed 004 Eq. 1-2)
// ---------------------------------------------------------------------------

/// Seed 004 Table 2's ambient TF. Its numerator and denominator share a
/// `(1 - q)` factor, which validation cancels.
fn ambient_tf_entry() -> TfEntry {
    TfEntry {
        output: 0,
        input: 1,
        a: hv(&[-0.0251, 0.0251, 0.0]),
        b: hv(&[1.0, -1.9985, 0.9985]),
    }
}

/// A seed 004 Eq. 2 bank on `T1` and `ambient_c` (both relative to the
/// first sample) into `dz_um`, at 1 s: `sp` on `T1` plus the ambient TF.
fn tf_with_ambient(sp: TfEntry) -> Model {
    Model {
        inputs: channels(&["T1", "ambient_c"], Reference::First),
        outputs: outputs(&["dz_um"]),
        dt_s: 1.0,
        params: Params::Tf(hv(&[sp, ambient_tf_entry()])),
        bounds: None,
        five_point: None,
    }
}

/// Seed 004 Table 3's SP1 (denominator with 3 delays, as printed) plus
/// Table 2's ambient TF.
pub fn tf_sp1_ambient() -> Model {
    tf_with_ambient(TfEntry {
        output: 0,
        input: 0,
        a: hv(&[-0.0337, 0.0332, 0.0]),
        b: hv(&[1.0, -1.3009, -0.3263, 0.6273]),
    })
}

/// Seed 004 Eq. 2 with Table 3's SP2 and Table 2's ambient TF, as
/// `examples/seed004_sp2_ambient.toml` writes it.
pub fn tf_sp2_ambient() -> Model {
    tf_with_ambient(TfEntry {
        output: 0,
        input: 0,
        a: hv(&[16.0005, -15.9975, 0.0]),
        b: hv(&[1.0, -0.99983]),
    })
}

/// Four temperatures, each through a 4/4-order TF (five coefficients in `a`
/// and `b`, thermal time constants from seconds to 1000 samples), into
/// two outputs: a bank larger than any seed 004 prints.
pub fn tf_bank_4x4() -> Model {
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
            b: hv(&from_roots(p)),
        })
        .collect();
    Model {
        inputs: channels(&["T1", "T2", "T3", "T4"], Reference::First),
        outputs: outputs(&["dx_um", "dz_um"]),
        dt_s: 1.0,
        params: Params::Tf(hv(&entries)),
        bounds: None,
        five_point: None,
    }
}

// ---------------------------------------------------------------------------
// Regressions (seeds 002 and 003)
// ---------------------------------------------------------------------------

/// Seed 002 Eq. 6: `x_m = -0.2565 + 0.0189 T3 - 0.0124 T4 + 0.0082 T10 - 0.0074 T12`.
pub fn linear_seed002() -> Model {
    let values = [0.0189, -0.0124, 0.0082, -0.0074];
    Model {
        inputs: channels(&["T3", "T4", "T10", "T12"], Reference::Absolute),
        outputs: outputs(&["x_um"]),
        dt_s: 0.0,
        params: Params::Linear(Linear {
            outputs: hv(&[LinearOutput {
                output: 0,
                intercept: -0.2565,
                coef: (0u8..)
                    .zip(values)
                    .map(|(channel, value)| Coef { channel, value })
                    .collect(),
                position: None,
            }]),
        }),
        bounds: None,
        five_point: None,
    }
}

/// Seed 003 Eq. 13 and 14 (one principal component of five temperatures);
/// with `position`, Eq. 16's fifth-order Y-axis positioning-error polynomial
/// (k0 = -0.0171) on a sixth channel `y_mm`.
pub fn pcr_seed003(position: bool) -> Model {
    let mut inputs = channels(&["T1", "T2", "T5", "T7", "T11"], Reference::Absolute);
    let position = position.then(|| {
        inputs
            .push(chan("y_mm", Reference::Absolute))
            .expect("room");
        PositionTerm {
            channel: 5,
            poly: hv(&[-1.6437, 0.0, -0.0144, 1.5173e-4, -5.5207e-7, 6.8499e-10]),
            k0: -0.0171,
        }
    });
    Model {
        inputs,
        outputs: outputs(&["k"]),
        dt_s: 0.0,
        params: Params::Pcr(Pcr {
            inputs: hv(&[0, 1, 2, 3, 4]),
            components: hv(&[Component {
                intercept: -50.6062,
                weights: hv(&[0.1631, 0.4902, 0.2512, 0.6614, 1.1666]),
            }]),
            outputs: hv(&[PcrOutput {
                output: 0,
                intercept: -0.3243,
                beta: hv(&[0.0396]),
                position,
            }]),
        }),
        bounds: None,
        five_point: None,
    }
}

// ---------------------------------------------------------------------------
// BP nets (seeds 000 and 003, MATLAB `feedforwardnet` conventions)
// ---------------------------------------------------------------------------

/// An m-n-3 tansig/purelin net with [`weights`] (seed 000's is 4-11-3: four
/// temperatures in, elongation and two tilt angles out).
pub fn bp(m: usize, n: usize) -> Model {
    let inputs: Vec<String> = (1..=m).map(|i| format!("T{i}")).collect();
    let inputs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    Model {
        inputs: channels(&inputs, Reference::Absolute),
        outputs: outputs(&["dz_um", "tilt_x_urad", "tilt_y_urad"]),
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
        bounds: None,
        five_point: None,
    }
}

/// A small 3-4-2 net (tansig hidden layer, purelin outputs) with made-up
/// weights: the decoder does not care where weights come from.
pub fn bp_3_4_2() -> Model {
    Model {
        inputs: channels(&["T1", "T2", "T3"], Reference::Absolute),
        outputs: outputs(&["dx_um", "dz_um"]),
        dt_s: 0.0,
        params: Params::Bp(BpNet {
            inputs: hv(&[0, 1, 2]),
            outputs: hv(&[0, 1]),
            hidden_activation: Activation::Tansig,
            output_activation: Activation::Purelin,
            w1: hv(&[
                0.5, -0.25, 0.125, 1.0, 0.0, -0.75, -0.3, 0.6, 0.2, 0.05, -0.45, 0.9,
            ]),
            b1: hv(&[0.1, -0.2, 0.3, -0.4]),
            w2: hv(&[0.8, -0.6, 0.4, 0.2, -0.1, 0.7, -0.5, 0.3]),
            b2: hv(&[0.05, -0.05]),
            x_min: hv(&[18.0, 19.0, 20.0]),
            x_max: hv(&[35.0, 38.0, 41.0]),
            y_min: hv(&[-5.0, -40.0]),
            y_max: hv(&[5.0, 2.0]),
        }),
        bounds: None,
        five_point: None,
    }
}

// ---------------------------------------------------------------------------
// ARMA (seed 001)
// ---------------------------------------------------------------------------

/// ARMA(2, 1) on the once-differenced, standardised series (seed 001's form),
/// one sample a minute.
pub fn arma_2_1_d1() -> Model {
    Model {
        inputs: channels(&["dz_um"], Reference::Absolute),
        outputs: outputs(&["dz_um"]),
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
        bounds: None,
        five_point: None,
    }
}

// ---------------------------------------------------------------------------
// Filter banks (seed 004's parallel form with fixed real poles)
// ---------------------------------------------------------------------------

/// Three inputs (`T1`, `T2` relative to their first sample, `ambient_c`
/// relative to 20 C), five features (raw T1, T1 filtered with tau 10 min
/// and 1 h, T2 squared and filtered with tau 30 min, raw ambient), into
/// `dz_um` and `dx_um` at 30 s; with calibration bounds when `bounds`.
pub fn fbank_3x2(bounds: bool) -> Model {
    let f = |input: u8, power: u8, tau_s: f64| Feature {
        input,
        power,
        tau_s,
    };
    Model {
        inputs: hv(&[
            chan("T1", Reference::First),
            chan("T2", Reference::First),
            chan("ambient_c", Reference::Value(20.0)),
        ]),
        outputs: outputs(&["dz_um", "dx_um"]),
        dt_s: 30.0,
        params: Params::Fbank(FilterBank {
            features: hv(&[
                f(0, 1, 0.0),
                f(0, 1, 600.0),
                f(0, 1, 3600.0),
                f(1, 2, 1800.0),
                f(2, 1, 0.0),
            ]),
            outputs: hv(&[
                FbOutput {
                    output: 0,
                    intercept: 0.5,
                    coef: hv(&[1.2, 3.5, -2.0, 0.04, -0.8]),
                },
                FbOutput {
                    output: 1,
                    intercept: -0.1,
                    coef: hv(&[0.0, 0.6, 0.3, 0.0, 0.2]),
                },
            ]),
        }),
        bounds: bounds.then(|| Bounds {
            envelope: hv(&[
                Span {
                    min: -0.5,
                    max: 12.0,
                },
                Span { min: 0.0, max: 8.0 },
                Span {
                    min: -3.0,
                    max: 4.0,
                },
            ]),
            half_width: hv(&[1.8, 0.9]),
            growth: hv(&[1.0, 3.0]),
        }),
        five_point: None,
    }
}

/// `n_in` temperatures (first-sample reference), each raw and low-pass
/// filtered at 10 min, 1 h and 4 h, into one output at 1 s (32 x 4 = 128
/// features: the largest bank before model-core took 256).
pub fn fbank_wide(n_in: usize) -> Model {
    fbank_sized(n_in, &[0.0, 600.0, 3600.0, 14_400.0], &["dz_um"])
}

/// `n_in` temperatures (first-sample reference), each through every time
/// constant of `taus` (0: as is), into the outputs `outs` at 1 s; output
/// `o`'s weights are [`weights`] with salt `0.3 + o`.
pub fn fbank_sized(n_in: usize, taus: &[f64], outs: &[&str]) -> Model {
    let names: Vec<String> = (1..=n_in).map(|i| format!("T{i}")).collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut features = heapless::Vec::new();
    for i in 0..n_in {
        for &tau_s in taus {
            features
                .push(Feature {
                    input: u8::try_from(i).expect("few inputs"),
                    power: 1,
                    tau_s,
                })
                .expect("at most MAX_FB_FEATURES features");
        }
    }
    let bank_outputs: Vec<FbOutput> = (0..outs.len())
        .map(|o| FbOutput {
            output: u8::try_from(o).expect("few outputs"),
            intercept: 0.0,
            coef: hv(&weights(features.len(), 0.3 + o as f64)),
        })
        .collect();
    Model {
        inputs: channels(&refs, Reference::First),
        outputs: outputs(outs),
        dt_s: 1.0,
        params: Params::Fbank(FilterBank {
            features,
            outputs: hv(&bank_outputs),
        }),
        bounds: None,
        five_point: None,
    }
}
