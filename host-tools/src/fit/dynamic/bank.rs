//! The TF bank the dynamic trainers export: entries built with checked
//! sizes, the bank validated by the model core (so a fitted model that the
//! hub would refuse never leaves the trainer), and each entry's step
//! response (gain, time constant, poles) for the JSON.

use crate::data::dataset::Dataset;
use crate::fit::{channels, outputs};
use anyhow::{anyhow, bail, Result};
use model_core::tf::{RealisedTf, TfEntry, TfHistory, MAX_ORDER, MAX_TF_ENTRIES};
use model_core::{Model, Params, ValidModel};
use nalgebra::DMatrix;
use serde::Serialize;

/// A TF-bank model over `ds`'s inputs and targets, validated by the model core.
pub fn bank(ds: &Dataset, dt: f64, entries: Vec<TfEntry>) -> Result<ValidModel> {
    let n = entries.len();
    let bank = heapless::Vec::<TfEntry, MAX_TF_ENTRIES>::from_iter(
        entries.into_iter().take(MAX_TF_ENTRIES),
    );
    if bank.len() != n {
        bail!("{n} TF entries; the model holds at most {MAX_TF_ENTRIES}");
    }
    Model {
        inputs: channels(ds)?,
        outputs: outputs(ds)?,
        dt_s: dt,
        params: Params::Tf(bank),
        bounds: None,
        five_point: None,
    }
    .validate()
    .map_err(|e| anyhow!("{e}"))
}

/// Builds a TF entry (checked sizes).
pub fn entry(output: usize, input: usize, a: &[f64], b: &[f64]) -> Result<TfEntry> {
    Ok(TfEntry {
        output: u8::try_from(output)?,
        input: u8::try_from(input)?,
        a: heapless::Vec::from_slice(a)
            .map_err(|_| anyhow!("numerator above order {MAX_ORDER}"))?,
        b: heapless::Vec::from_slice(b)
            .map_err(|_| anyhow!("denominator above order {MAX_ORDER}"))?,
    })
}

/// Step-response figures of one TF entry, or why the model core refused
/// to realise it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum StepInfo {
    /// The realised TF's figures.
    Figures(StepFigures),
    /// The model core's refusal.
    Refused {
        /// Why (the model core's message).
        error: String,
    },
}

/// A TF's step response (fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StepFigures {
    /// Pole-zero pairs the model core cancelled when realising it.
    pub cancelled_pole_zero_pairs: u8,
    /// Steady-state (DC) gain, target unit per input unit (um/K for a temperature).
    pub gain_per_unit: f64,
    /// Whether any pole-zero pair was cancelled.
    pub pole_zero_cancellation: bool,
    /// Poles in z, `[re, im]`.
    pub poles: Vec<[f64; 2]>,
    /// 63.2 % rise time of the unit-step response, s ([`time_constant`]).
    pub tau_s: Option<f64>,
}

/// Step-response figures of one TF, from its realisation in the model core.
pub fn step_info(a: &[f64], b: &[f64], dt: f64) -> StepInfo {
    let tf = match RealisedTf::new(a, b) {
        Ok(tf) => tf,
        Err(e) => {
            return StepInfo::Refused {
                error: e.to_string(),
            }
        }
    };
    StepInfo::Figures(StepFigures {
        cancelled_pole_zero_pairs: tf.cancelled(),
        gain_per_unit: tf.dc_gain(),
        pole_zero_cancellation: tf.cancelled() > 0,
        poles: poles(tf.denominator()),
        tau_s: time_constant(&tf, dt),
    })
}

/// Time for the unit-step response to reach 63.2 % of its final value
/// (simulated on the realised TF, linear interpolation between samples);
/// `None` for a zero gain or when it takes more than ten million samples.
pub fn time_constant(tf: &RealisedTf, dt: f64) -> Option<f64> {
    let gain = tf.dc_gain();
    if gain == 0.0 || !gain.is_finite() {
        return None;
    }
    let target = (1.0 - (-1.0f64).exp()) * gain;
    let mut h = TfHistory::default();
    let mut prev = 0.0;
    for k in 0..10_000_000u32 {
        let y = tf.output(&h, 1.0);
        if (y - target) * gain.signum() >= 0.0 {
            let frac = if k == 0 || y == prev {
                0.0
            } else {
                (target - prev) / (y - prev)
            };
            return Some((f64::from(k) - 1.0 + frac).max(0.0) * dt);
        }
        h.push(1.0, y);
        prev = y;
    }
    None
}

/// Roots of a denominator `[1, d1, ..]` in z (the poles), as `[re, im]`.
fn poles(den: &[f64]) -> Vec<[f64; 2]> {
    let n = den.len().saturating_sub(1);
    if n == 0 {
        return Vec::new();
    }
    // Companion matrix of z^n + d1 z^(n-1) + .. + dn.
    let c = DMatrix::from_fn(n, n, |i, j| {
        if i == 0 {
            -den[j + 1]
        } else if i == j + 1 {
            1.0
        } else {
            0.0
        }
    });
    c.complex_eigenvalues()
        .iter()
        .map(|z| [z.re, z.im])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_time_constant_is_tau() {
        // ZOH discretisation of K/(tau s + 1), tau = 300 samples: the 63.2 %
        // time is tau within one sample (the response is sampled).
        let p = (-1.0f64 / 300.0).exp();
        let tf = RealisedTf::new(&[0.0, 4.0 * (1.0 - p)], &[1.0, -p]).unwrap();
        let tau = time_constant(&tf, 1.0).unwrap();
        assert!((tau - 300.0).abs() < 1.0, "{tau}");
        assert!((tf.dc_gain() - 4.0).abs() < 1e-12);
    }

    #[test]
    fn an_unrealisable_entry_reports_only_the_error() {
        // A pole at z = 2: the model core refuses it.
        let v = serde_json::to_value(step_info(&[1.0], &[1.0, -2.0], 1.0)).unwrap();
        let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
        assert_eq!(keys, ["error"], "{v}");
    }
}
