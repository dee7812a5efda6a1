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

use super::align::Aligned;
use super::candidates::{self, round};
use super::outcome::{Comparison, Deployment, Trained};
use super::problem::{Problem, Rows};
use super::spill::Spill;
use crate::num::linalg;
use crate::num::lsq;
use anyhow::{Context, Result};

/// The effect is added to a channel only where it explains at least this
/// share of the fit-part residual rms the baseline leaves (the verdict
/// rule's 20 %, in-sample): on a channel the effect does not reach, its
/// regressors would only fit the twin's mismatch and add that to the
/// training data.
const MIN_FIT_SHRINK: f64 = 0.2;

/// Rows of every channel used read back per block while training and
/// scoring (the channels are spilled, [`super::align::Channels`]).
const BLOCK_ROWS: usize = 1 << 16;

/// `rows` in blocks of [`BLOCK_ROWS`].
fn blocks(rows: Rows) -> impl Iterator<Item = Rows> {
    rows.clone()
        .step_by(BLOCK_ROWS)
        .map(move |a| a..(a + BLOCK_ROWS).min(rows.end))
}

/// A channel's values on a block of rows: `(channel, rows) -> values`.
type Values<'a> = dyn Fn(usize, Rows) -> Vec<f64> + 'a;

/// The compensation target: the main channel if it is a displacement, else
/// `dz_um` (the axial error compensation cares most about), else the first
/// displacement.
fn target(al: &Aligned, main: usize) -> Option<usize> {
    let ch = &al.channels;
    if ch.is_displacement(main) {
        return Some(main);
    }
    ch.position("dz_um")
        .or_else(|| (0..ch.len()).find(|&i| ch.is_displacement(i)))
}

/// Trains `y ~ b0 + sum b_i x_i` on rows `0..n_fit`, the inputs and the
/// target streamed a block of rows at a time from `value`
/// ([`linalg::least_squares_visit`]: the rows are not copied whole);
/// `None` if the solver refuses (too few rows, SVD failure).
fn train(value: &Values, inputs: &[usize], tgt: usize, n_fit: usize) -> Option<(f64, Vec<f64>)> {
    let mut x = vec![0.0; inputs.len()];
    linalg::least_squares_visit(inputs.len(), &mut |f| {
        for rows in blocks(0..n_fit) {
            let cols: Vec<Vec<f64>> = inputs.iter().map(|&i| value(i, rows.clone())).collect();
            let y = value(tgt, rows.clone());
            for (k, yk) in y.iter().enumerate() {
                for (v, c) in x.iter_mut().zip(&cols) {
                    *v = c[k];
                }
                f(&x, *yk);
            }
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
) -> Trained {
    let n = al.t_s.len();
    let (b0, b) = model;
    let mut r = Vec::with_capacity(n - n_fit);
    let (mut abs_r, mut abs_y) = (0.0, 0.0);
    for rows in blocks(n_fit..n) {
        let y = al.channels.real_rows(tgt, rows.clone());
        let cols: Vec<Vec<f64>> = inputs
            .iter()
            .map(|&i| al.channels.real_rows(i, rows.clone()))
            .collect();
        for (k, yk) in y.iter().enumerate() {
            let yhat = b0 + cols.iter().zip(b).map(|(c, w)| w * c[k]).sum::<f64>();
            r.push(yk - yhat);
            abs_r += (yk - yhat).abs();
            abs_y += yk.abs();
        }
    }
    let reduction = if abs_y > 0.0 {
        100.0 * (1.0 - abs_r / abs_y)
    } else {
        0.0
    };
    Trained::Scored {
        reduction_pct: round(reduction),
        rmse_um: round(lsq::rms(&r)),
    }
}

/// The compensation model's kind.
const MODEL: &str = "mlr";

/// No deployment view, and why.
fn skipped(note: &str) -> Deployment {
    Deployment::Skipped {
        model: MODEL.into(),
        note: note.into(),
    }
}

/// The deployment view of a diagnosis (see the module doc). `Err` only
/// when the effect parts cannot be written to their temporary file or read
/// back from it.
pub fn deployment(al: &Aligned, main: usize, n_fit: usize, verdict: &str) -> Result<Deployment> {
    let Some(tgt) = target(al, main) else {
        return Ok(skipped("no displacement channel to compensate"));
    };
    let ch = &al.channels;
    let inputs: Vec<usize> = (0..ch.len())
        .filter(|&i| !ch.is_displacement(i) && !ch.name(i).starts_with('S'))
        .collect();
    if inputs.is_empty() {
        return Ok(skipped("no temperature channel shared by both files"));
    }
    let fit_on = |value: &Values| -> Trained {
        match train(value, &inputs, tgt, n_fit) {
            Some(m) => score(&m, al, &inputs, tgt, n_fit),
            None => Trained::Failed {
                error: "least squares failed".into(),
            },
        }
    };
    let mut out = Comparison {
        effect: None,
        held_out_uncompensated_rms_um: round(lsq::rms(&ch.real_rows(tgt, n_fit..al.t_s.len()))),
        improvement_pct: None,
        inputs: inputs.iter().map(|&i| ch.name(i).to_string()).collect(),
        model: MODEL.into(),
        note: None,
        target: ch.name(tgt).to_string(),
        trained_on: "fit rows (before holdout_from_t_s); scored on the real run's held-out rows"
            .into(),
        trained_on_real_fit_part: fit_on(&|i, rows| ch.real_rows(i, rows)),
        trained_on_sim: fit_on(&|i, rows| ch.sim_rows(i, rows)),
        trained_on_sim_plus_effect: None,
    };
    if verdict == "none" {
        out.note = Some(
            "verdict none: no effect to add; only the model trained on the nominal sim".into(),
        );
        return Ok(Deployment::Compared(Box::new(out)));
    }
    let effect = effects(al, &inputs, tgt, n_fit, verdict)
        .context("cannot write diagnose's temporary file")?;
    let on_eff = fit_on(&|i, rows: Rows| {
        let mut s = ch.sim_rows(i, rows.clone());
        if let Some(col) = effect.cols[i] {
            let e = effect.spill.rows_of(col, rows);
            s.iter_mut().zip(&e).for_each(|(s, e)| *s += e);
        }
        s
    });
    effect.spill.check()?;
    out.improvement_pct = Some(improvement(&out.trained_on_sim, &on_eff));
    out.trained_on_sim_plus_effect = Some(on_eff);
    out.effect = Some(verdict.to_string());
    Ok(Deployment::Compared(Box::new(out)))
}

/// How much the model trained on the sim plus the effect lowers the held-out
/// rmse of the one trained on the sim alone, % (not finite without both).
fn improvement(on_sim: &Trained, on_effect: &Trained) -> f64 {
    match (on_sim.rmse_um(), on_effect.rmse_um()) {
        (Some(a), Some(b)) if a > 0.0 => round(100.0 * (1.0 - b / a)),
        _ => f64::NAN,
    }
}

/// The effect's part of each channel used, where it is added (else the
/// sim alone), spilled as it is made: `cols[i]` is channel `i`'s column
/// in `spill`, if any.
struct Effects {
    spill: Spill,
    cols: Vec<Option<usize>>,
}

/// The verdict's part of the target and of each input channel where it
/// explains [`MIN_FIT_SHRINK`] of the fit part ([`candidates::effect_part`]),
/// one channel loaded at a time.
fn effects(
    al: &Aligned,
    inputs: &[usize],
    tgt: usize,
    n_fit: usize,
    verdict: &str,
) -> std::io::Result<Effects> {
    let mut out = Effects {
        spill: Spill::new(al.t_s.len())?,
        cols: vec![None; al.channels.len()],
    };
    for i in (0..al.channels.len()).filter(|&i| i == tgt || inputs.contains(&i)) {
        let ch = al.channels.load(i);
        let p = Problem::new(al, &ch, n_fit);
        let part = candidates::effect_part(verdict, &p)
            .filter(|e| e.fit_rms_with <= (1.0 - MIN_FIT_SHRINK) * e.fit_rms_base);
        if let Some(e) = part {
            out.cols[i] = Some(out.spill.push(&e.values)?);
        }
    }
    Ok(out)
}
