//! The deployment view: what the diagnosed effect is worth to a user who
//! trains a compensation model on the twin.
//!
//! A multiple linear regression of the main displacement on the temperature
//! channels both files share (the model `thermcomp fit --model mlr` trains,
//! by the same solver, [`crate::num::linalg::least_squares`]) is trained on
//! the fit rows (before the hold-out) of
//!
//! 1. the nominal sim,
//! 2. the sim with the verdict's effect added to every channel (inputs and
//!    target): on each channel the verdict's candidate is fitted to that
//!    channel's residual the way it is fitted on the main channel
//!    ([`candidates::effect_part`]: fit rows only) and its effect-specific
//!    part (without the baseline's offset, drift and gain) is added,
//! 3. the real run itself (the reference: what real calibration data buys),
//!
//! and each is scored on the real run's held-out rows (real temperatures in,
//! real displacement to match). If 2 beats 1 the effect is worth adding to
//! the twin before training compensation on it.

use super::align::{Aligned, Channel};
use super::candidates::{self, round, Problem};
use crate::num::linalg;
use crate::num::lsq;
use serde_json::{json, Value};

/// The effect is added to a channel only where it explains at least this
/// share of the fit-part residual rms the baseline leaves (the verdict
/// rule's 20 %, in-sample): on a channel the effect does not reach, its
/// regressors would only fit the twin's mismatch and add that to the
/// training data.
const MIN_FIT_SHRINK: f64 = 0.2;

/// The compensation target: the main channel if it is a displacement, else
/// `dz_um` (the axial error compensation cares most about), else the first
/// displacement.
fn target(al: &Aligned, main: usize) -> Option<usize> {
    if al.channels[main].is_displacement() {
        return Some(main);
    }
    al.channels
        .iter()
        .position(|c| c.name == "dz_um")
        .or_else(|| al.channels.iter().position(Channel::is_displacement))
}

/// Trains `y ~ b0 + sum b_i x_i` on rows `0..n_fit`, the inputs and the
/// target streamed from `value(channel, row)` ([`linalg::least_squares_visit`]:
/// the rows are not copied); `None` if the solver refuses (too few rows,
/// SVD failure).
fn train(
    value: &dyn Fn(usize, usize) -> f64,
    inputs: &[usize],
    tgt: usize,
    n_fit: usize,
) -> Option<(f64, Vec<f64>)> {
    let mut x = vec![0.0; inputs.len()];
    linalg::least_squares_visit(inputs.len(), &mut |f| {
        for k in 0..n_fit {
            for (v, &i) in x.iter_mut().zip(inputs) {
                *v = value(i, k);
            }
            f(&x, value(tgt, k));
        }
    })
    .ok()
}

/// Scores a trained model on the real run's held-out rows: rmse and the
/// CONTRACT's reduction % (`1 - mean|y - yhat| / mean|y|`).
fn score(
    model: &(f64, Vec<f64>),
    al: &Aligned,
    inputs: &[usize],
    tgt: usize,
    n_fit: usize,
) -> Value {
    let n = al.t_s.len();
    let (b0, b) = model;
    let mut r = Vec::with_capacity(n - n_fit);
    let (mut abs_r, mut abs_y) = (0.0, 0.0);
    for k in n_fit..n {
        let yk = al.channels[tgt].real_at(k);
        let yhat = b0
            + inputs
                .iter()
                .zip(b)
                .map(|(&i, w)| w * al.channels[i].real_at(k))
                .sum::<f64>();
        r.push(yk - yhat);
        abs_r += (yk - yhat).abs();
        abs_y += yk.abs();
    }
    let reduction = if abs_y > 0.0 {
        100.0 * (1.0 - abs_r / abs_y)
    } else {
        0.0
    };
    json!({"rmse_um": round(lsq::rms(&r)), "reduction_pct": round(reduction)})
}

/// The `deployment` object of the diagnose JSON (see the module doc).
pub fn deployment(al: &Aligned, main: usize, n_fit: usize, verdict: &str) -> Value {
    let Some(tgt) = target(al, main) else {
        return json!({"model": "mlr", "note": "no displacement channel to compensate"});
    };
    let inputs: Vec<usize> = (0..al.channels.len())
        .filter(|&i| !al.channels[i].is_displacement() && !al.channels[i].name.starts_with('S'))
        .collect();
    if inputs.is_empty() {
        return json!({"model": "mlr", "note": "no temperature channel shared by both files"});
    }
    let names: Vec<&str> = inputs
        .iter()
        .map(|&i| al.channels[i].name.as_str())
        .collect();
    let held_out_rms = lsq::rms(&al.channels[tgt].real()[n_fit..]);
    let fit_on = |value: &dyn Fn(usize, usize) -> f64| -> Value {
        match train(value, &inputs, tgt, n_fit) {
            Some(m) => score(&m, al, &inputs, tgt, n_fit),
            None => json!({"error": "least squares failed"}),
        }
    };
    let on_sim = fit_on(&|i, k| al.channels[i].sim[k]);
    let on_real = fit_on(&|i, k| al.channels[i].real_at(k));
    let mut out = json!({
        "model": "mlr",
        "target": al.channels[tgt].name,
        "inputs": names,
        "trained_on": "fit rows (before holdout_from_t_s); scored on the real run's held-out rows",
        "held_out_uncompensated_rms_um": round(held_out_rms),
        "trained_on_sim": on_sim,
        "trained_on_real_fit_part": on_real,
    });
    if verdict == "none" {
        out["trained_on_sim_plus_effect"] = Value::Null;
        out["note"] =
            json!("verdict none: no effect to add; only the model trained on the nominal sim");
        return out;
    }
    // The effect's part of each channel used, where it is added (else the
    // sim alone).
    let effect: Vec<Option<Vec<f64>>> = (0..al.channels.len())
        .map(|i| {
            if i != tgt && !inputs.contains(&i) {
                return None;
            }
            let p = Problem::new(al, &al.channels[i], n_fit);
            candidates::effect_part(verdict, &p)
                .filter(|e| e.fit_rms_with <= (1.0 - MIN_FIT_SHRINK) * e.fit_rms_base)
                .map(|e| e.values)
        })
        .collect();
    let on_eff = fit_on(&|i, k| {
        let s = al.channels[i].sim[k];
        effect[i].as_ref().map_or(s, |e| s + e[k])
    });
    let gain = match (on_sim["rmse_um"].as_f64(), on_eff["rmse_um"].as_f64()) {
        (Some(a), Some(b)) if a > 0.0 => json!(round(100.0 * (1.0 - b / a))),
        _ => Value::Null,
    };
    out["trained_on_sim_plus_effect"] = on_eff;
    out["effect"] = json!(verdict);
    out["improvement_pct"] = gain;
    out
}
