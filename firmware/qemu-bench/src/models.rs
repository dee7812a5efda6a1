//! The largest model of each kind that model-core accepts, with made-up but
//! valid coefficients (stable TFs, stationary and invertible ARMA).
//!
//! Sizes, from model-core's limits: TF bank of `MAX_TF_ENTRIES` (16) entries
//! of order `MAX_ORDER` (8); BP 16-24-3 (`MAX_W1` = 384 = 16 x 24); linear 16
//! inputs x 3 outputs; PCR 16 inputs, `MAX_COMPONENTS` (8) components, 3
//! outputs; ARMA(`MAX_ARMA_ORDER`, `MAX_ARMA_ORDER`) = (10, 10), d = 1.
//! Every model reads the same 16 temperature channels, but the filter bank:
//! 32 channels (`WIDE_CHANNELS`, two banks of 16 front ends) x 8 features
//! (`MAX_FB_FEATURES` = 256) into dx, dy and dz.

use heapless::Vec;
use model_core::arma::{Arma, MAX_ARMA_ORDER};
use model_core::bp::{Activation, BpNet, MAX_W1};
use model_core::fbank::{FbOutput, Feature, FilterBank, MAX_FB_FEATURES};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::pcr::{Component, Pcr, PcrOutput, MAX_COMPONENTS};
use model_core::tf::{TfEntry, MAX_COEFFS, MAX_ORDER, MAX_TF_ENTRIES};
use model_core::{Channel, Model, ModelKind, Name, Params, Reference};

/// Temperature channels read each sample (16 MAX31865 front ends).
pub const CHANNELS: usize = 16;
/// Channels of the widest model (the filter bank): the model-core maximum.
pub const WIDE_CHANNELS: usize = model_core::model::MAX_CHANNELS;
/// Outputs: dx, dy, dz.
pub const OUTPUTS: usize = 3;
/// Hidden neurons of the BP net: the most that 16 inputs allow.
pub const BP_HIDDEN: usize = MAX_W1 / CHANNELS;

const _: () = assert!(MAX_TF_ENTRIES == CHANNELS, "one TF entry per channel");
const _: () = assert!(BP_HIDDEN == 24);
const _: () = assert!(WIDE_CHANNELS == 2 * CHANNELS && MAX_FB_FEATURES == 8 * WIDE_CHANNELS);

/// The kinds, in the order of the table.
pub const KINDS: [ModelKind; 6] = [
    ModelKind::Tf,
    ModelKind::Bp,
    ModelKind::Linear,
    ModelKind::Pcr,
    ModelKind::Arma,
    ModelKind::Fbank,
];

/// A one-line description of the size built for `kind`.
pub fn size_label(kind: ModelKind) -> &'static str {
    match kind {
        ModelKind::Tf => "16 entries x order 8/8",
        ModelKind::Bp => "16-24-3, tansig/purelin",
        ModelKind::Linear => "16 in x 3 out",
        ModelKind::Pcr => "16 in, 8 comp, 3 out",
        ModelKind::Arma => "(10,10), d = 1",
        ModelKind::Fbank => {
            "32 in x 8 features (tau 0, 5, 15, 45 min, 2.25, 6.75, 20.25 h, hold) x 3 out"
        }
    }
}

const NAMES: [&str; WIDE_CHANNELS] = [
    "T1", "T2", "T3", "T4", "T5", "T6", "T7", "T8", "T9", "T10", "T11", "T12", "T13", "T14", "T15",
    "T16", "T17", "T18", "T19", "T20", "T21", "T22", "T23", "T24", "T25", "T26", "T27", "T28",
    "T29", "T30", "T31", "T32",
];
const OUTPUT_NAMES: [&str; OUTPUTS] = ["dx_um", "dy_um", "dz_um"];

fn name(s: &str) -> Name {
    Name::try_from(s).unwrap_or_default()
}

fn inputs(reference: Reference) -> Vec<Channel, { model_core::model::MAX_CHANNELS }> {
    NAMES
        .iter()
        .take(CHANNELS)
        .map(|n| Channel {
            name: name(n),
            reference,
        })
        .collect()
}

fn outputs(n: usize) -> Vec<Name, { model_core::model::MAX_OUTPUTS }> {
    OUTPUT_NAMES.iter().take(n).map(|n| name(n)).collect()
}

/// A deterministic, varied coefficient in [-1, 1] (no libm, no RNG).
fn coef(i: usize) -> f64 {
    let k = (i * 37 + 11) % 101;
    (k as f64 - 50.0) / 50.0
}

/// Coefficients (highest power first, leading 1) of the product of the real
/// factors `(1 - r z^-1)` and quadratic factors `(1 - s z^-1 + q z^-2)`.
fn poly<const N: usize>(real: &[f64], quadratic: &[(f64, f64)]) -> Vec<f64, N> {
    let mut c: Vec<f64, N> = Vec::new();
    let _ = c.push(1.0);
    let mut mul = |f: &[f64]| {
        let old = c.clone();
        c.clear();
        for k in 0..old.len() + f.len() - 1 {
            let mut v = 0.0;
            for (j, fj) in f.iter().enumerate() {
                if k >= j {
                    if let Some(o) = old.get(k - j) {
                        v += fj * o;
                    }
                }
            }
            let _ = c.push(v);
        }
    };
    for r in real {
        mul(&[1.0, -r]);
    }
    for (s, q) in quadratic {
        mul(&[1.0, -s, *q]);
    }
    c
}

/// TF bank: one order-8 entry per channel (`MAX_TF_ENTRIES` = 16), outputs
/// taken in turn. Poles: two complex pairs (|p| = 0.95, 0.8) and four real
/// poles, all distinct and inside the unit circle; zeros elsewhere.
pub fn tf() -> Model {
    let entries = (0..MAX_TF_ENTRIES)
        .map(|e| {
            let shift = e as f64 * 0.004;
            let b: Vec<f64, MAX_COEFFS> = poly(
                &[0.9 - shift, 0.7, 0.5 + shift, 0.2],
                &[(1.5, 0.9025), (0.6 + shift, 0.64)],
            );
            let zeros: Vec<f64, MAX_COEFFS> = poly(
                &[0.6, -0.3 + shift, 0.1, -0.5, 0.35, -0.15, 0.45, -0.65],
                &[],
            );
            let gain = 0.002 * (1.0 + coef(e) * 0.5);
            let a = zeros.iter().map(|z| gain * z).collect();
            TfEntry {
                output: (e % OUTPUTS) as u8,
                input: e as u8,
                a,
                b,
            }
        })
        .collect();
    Model {
        inputs: inputs(Reference::First),
        outputs: outputs(OUTPUTS),
        dt_s: 1.0,
        params: Params::Tf(entries),
        bounds: None,
        five_point: None,
    }
}

/// BP network 16-24-3 (tansig hidden, purelin output), inputs scaled from
/// 15..40 C, outputs to -30..30 um.
pub fn bp() -> Model {
    let net = BpNet {
        inputs: (0..CHANNELS as u8).collect(),
        outputs: (0..OUTPUTS as u8).collect(),
        hidden_activation: Activation::Tansig,
        output_activation: Activation::Purelin,
        w1: (0..CHANNELS * BP_HIDDEN).map(|i| 0.3 * coef(i)).collect(),
        b1: (0..BP_HIDDEN).map(|i| 0.1 * coef(i + 500)).collect(),
        w2: (0..BP_HIDDEN * OUTPUTS)
            .map(|i| 0.5 * coef(i + 900))
            .collect(),
        b2: (0..OUTPUTS).map(|i| 0.05 * coef(i + 1300)).collect(),
        x_min: (0..CHANNELS).map(|_| 15.0).collect(),
        x_max: (0..CHANNELS).map(|_| 40.0).collect(),
        y_min: (0..OUTPUTS).map(|_| -30.0).collect(),
        y_max: (0..OUTPUTS).map(|_| 30.0).collect(),
    };
    Model {
        inputs: inputs(Reference::Absolute),
        outputs: outputs(OUTPUTS),
        dt_s: 0.0,
        params: Params::Bp(net),
        bounds: None,
        five_point: None,
    }
}

/// Linear regression: 3 outputs, each on all 16 channels (against 20 C).
pub fn linear() -> Model {
    let lin = Linear {
        outputs: (0..OUTPUTS)
            .map(|o| LinearOutput {
                output: o as u8,
                intercept: coef(o),
                coef: (0..CHANNELS)
                    .map(|i| Coef {
                        channel: i as u8,
                        value: coef(o * CHANNELS + i),
                    })
                    .collect(),
                position: None,
            })
            .collect(),
    };
    Model {
        inputs: inputs(Reference::Value(20.0)),
        outputs: outputs(OUTPUTS),
        dt_s: 0.0,
        params: Params::Linear(lin),
        bounds: None,
        five_point: None,
    }
}

/// Principal component regression: 16 inputs, 8 components, 3 outputs.
pub fn pcr() -> Model {
    let p = Pcr {
        inputs: (0..CHANNELS as u8).collect(),
        components: (0..MAX_COMPONENTS)
            .map(|c| Component {
                intercept: coef(c + 200),
                weights: (0..CHANNELS).map(|i| coef(c * CHANNELS + i)).collect(),
            })
            .collect(),
        outputs: (0..OUTPUTS)
            .map(|o| PcrOutput {
                output: o as u8,
                intercept: coef(o + 300),
                beta: (0..MAX_COMPONENTS).map(|c| coef(o * 8 + c + 400)).collect(),
                position: None,
            })
            .collect(),
    };
    Model {
        inputs: inputs(Reference::Value(20.0)),
        outputs: outputs(OUTPUTS),
        dt_s: 0.0,
        params: Params::Pcr(p),
        bounds: None,
        five_point: None,
    }
}

/// ARMA(10, 10) with d = 1 on channel 0, forecasting output 0. AR and MA
/// polynomials have ten distinct real roots inside the unit circle.
pub fn arma() -> Model {
    // prod (z - r): c[0] = 1, then c[1..]; stationarity needs
    // 1 - phi_1 z^-1 - ... to have these roots, so phi = -c[1..].
    let ar: Vec<f64, { MAX_ARMA_ORDER + 1 }> = poly(
        &[0.9, 0.75, 0.6, 0.45, 0.3, 0.15, -0.1, -0.3, -0.5, -0.7],
        &[],
    );
    let ma: Vec<f64, { MAX_ARMA_ORDER + 1 }> = poly(
        &[0.5, 0.4, 0.3, 0.2, 0.1, -0.05, -0.15, -0.25, -0.35, -0.45],
        &[],
    );
    let a = Arma {
        channel: 0,
        output: 0,
        mean: 25.0,
        std: 2.0,
        diff: 1,
        constant: 0.0,
        phi: ar.iter().skip(1).map(|c| -c).collect(),
        theta: ma.iter().skip(1).copied().collect(),
    };
    Model {
        inputs: inputs(Reference::Absolute),
        outputs: outputs(1),
        dt_s: 1.0,
        params: Params::Arma(a),
        bounds: None,
        five_point: None,
    }
}

/// Filter bank: every one of 32 channels (first-sample reference) as is,
/// low-passed at the five time constants of the trainer's grid (5 min to
/// 6.75 h) and at 20.25 h, and held at its first sample (dt 1 s), into dx,
/// dy and dz.
pub fn fbank() -> Model {
    let mut features: Vec<Feature, MAX_FB_FEATURES> = Vec::new();
    for input in 0..WIDE_CHANNELS {
        for tau_s in [
            0.0,
            300.0,
            900.0,
            2700.0,
            8100.0,
            24_300.0,
            72_900.0,
            model_core::fbank::HOLD_TAU_S,
        ] {
            let _ = features.push(Feature {
                input: u8::try_from(input).unwrap_or(0),
                power: 1,
                tau_s,
            });
        }
    }
    let mut out: Vec<FbOutput, { model_core::model::MAX_OUTPUTS }> = Vec::new();
    for o in 0..OUTPUTS {
        let _ = out.push(FbOutput {
            output: u8::try_from(o).unwrap_or(0),
            intercept: 0.5,
            coef: (0..features.len()).map(|j| coef(j + o)).collect(),
        });
    }
    Model {
        inputs: NAMES
            .iter()
            .map(|n| Channel {
                name: name(n),
                reference: Reference::First,
            })
            .collect(),
        outputs: outputs(OUTPUTS),
        dt_s: 1.0,
        params: Params::Fbank(FilterBank {
            features,
            outputs: out,
        }),
        bounds: None,
        five_point: None,
    }
}

/// The model of `kind` at its largest size.
pub fn build(kind: ModelKind) -> Model {
    match kind {
        ModelKind::Tf => tf(),
        ModelKind::Bp => bp(),
        ModelKind::Linear => linear(),
        ModelKind::Pcr => pcr(),
        ModelKind::Arma => arma(),
        ModelKind::Fbank => fbank(),
    }
}

const _: () = assert!(MAX_ORDER == 8 && MAX_COEFFS == 9);
