//! What an update works on, per model output: the regressors the model
//! form gives each row of the new runs (linear inputs, PCR components, a
//! TF bank's per-entry series, or a filter bank's features) with the old
//! coefficients, and the model with new coefficients written back into its
//! form.

use super::rls::Coefs;
use crate::data::cells::Cells;
use crate::data::runfile::RunFile;
use crate::runner::{self, ColumnMap};
use anyhow::{anyhow, bail, Result};
use model_core::fbank::{FbOutput, FilterBank};
use model_core::linear::LinearOutput;
use model_core::pcr::{Pcr, PcrOutput};
use model_core::tf::TfEntry;
use model_core::{Model, Params, Reference, ValidModel};
use std::rc::Rc;

/// Per run, per row: one output's regressors (None where any is missing).
pub(crate) type Regressors = Vec<Vec<Option<Vec<f64>>>>;

/// Model-form inputs to one output's regressors.
pub(crate) type RegressorFn = Box<dyn Fn(&[f64]) -> Vec<f64>>;

/// The inputs as a static model sees them, per row (references applied as
/// the runner applies them: `first` is the first row where every input has
/// a value).
pub(crate) fn model_inputs(model: &ValidModel, run: &RunFile) -> Result<Vec<Option<Vec<f64>>>> {
    let cols: Vec<Cells<'_>> = model
        .inputs()
        .iter()
        .map(|ch| {
            run.column(&ch.name).ok_or_else(|| {
                anyhow!(
                    "{}: the model needs input \"{}\" but the run has no such column",
                    run.path.display(),
                    ch.name
                )
            })
        })
        .collect::<Result<_>>()?;
    let first = (0..run.len()).find(|&r| cols.iter().all(|c| c.get(r).is_some()));
    Ok((0..run.len())
        .map(|r| {
            let raw: Option<Vec<f64>> = cols.iter().map(|c| c.get(r)).collect();
            raw.map(|raw| {
                raw.iter()
                    .zip(model.inputs())
                    .zip(&cols)
                    .map(|((v, ch), col)| match ch.reference {
                        Reference::Absolute => *v,
                        Reference::Value(x) => v - x,
                        Reference::First => v - first.and_then(|f| col.get(f)).unwrap_or(*v),
                    })
                    .collect()
            })
        })
        .collect())
}

/// What one output's update works on: its regressors and the old coefficients.
pub(crate) struct Structure {
    /// `regs[run][row]` (shared by every output of a filter bank: its
    /// features are every output's regressors, each output's holds applied
    /// to its update rows, [`Hold::apply`]).
    pub(crate) regs: Rc<Regressors>,
    /// Old `(intercept, slopes)`; for a TF bank `(0, [1; entries])` (gains).
    pub(crate) old: Coefs,
    /// TF banks: the indices of this output's entries; they have no intercept.
    pub(crate) tf_entries: Option<Vec<usize>>,
    /// Filter banks: the output's hold features and the features tied to
    /// them (empty for the other forms).
    pub(crate) holds: Vec<Hold>,
}

/// A filter bank's hold feature (pole 1: the run's first value, `x0`) with
/// the output's other first-power features on its channel. A change-form
/// regression written on a logged channel (fit/auto/layout.rs) weighs the
/// hold by minus their sum, `sum b_j (F_j(x) - x0)`; the update keeps it so:
/// it regresses on `s_j - s_hold` and writes the hold back as `-sum b_j`.
/// A free hold column is constant within a run, so a least-squares window
/// on one run would fold `-sum b_j x0` of that run into the intercept, and
/// the next run, starting elsewhere, would be off by `sum b_j` times the
/// difference of the starts.
pub(crate) struct Hold {
    /// The hold feature's index.
    pub(crate) feature: usize,
    /// The tied features' indices.
    pub(crate) tied: Vec<usize>,
}

/// How far (relative to the weights' sizes) a hold's weight may be from
/// minus its tied features' sum and still count as tied: the rounding of
/// the sum the writer took (fit/auto/layout.rs).
const TIE_TOLERANCE: f64 = 1e-9;

impl Hold {
    /// The holds output `eq` weighs (non-zero coefficient) in `bank`, whose
    /// features have the `poles` model-core derived, that the old weights
    /// tie (the hold's weight minus its tied features' sum, within
    /// [`TIE_TOLERANCE`]). A hold the old model weighs freely (a bank not
    /// written in change form on a logged channel) stays a free column.
    fn of(bank: &FilterBank, eq: &FbOutput, poles: &[f64]) -> Vec<Hold> {
        let f = &bank.features;
        (0..f.len())
            .filter(|&h| poles.get(h) == Some(&1.0) && eq.coef.get(h).is_some_and(|c| *c != 0.0))
            .map(|h| Hold {
                feature: h,
                tied: (0..f.len())
                    .filter(|&j| {
                        j != h
                            && f[j].input == f[h].input
                            && f[j].power == 1
                            && poles.get(j) != Some(&1.0)
                    })
                    .collect(),
            })
            .filter(|hold| hold.ties(&eq.coef))
            .collect()
    }

    /// Whether weights `b` hold this hold's tie.
    fn ties(&self, b: &[f64]) -> bool {
        let w = |j: usize| b.get(j).copied().unwrap_or(0.0);
        let sum: f64 = self.tied.iter().map(|&j| w(j)).sum();
        let size = w(self.feature).abs() + self.tied.iter().map(|&j| w(j).abs()).sum::<f64>();
        !self.tied.is_empty() && (w(self.feature) + sum).abs() <= TIE_TOLERANCE * size
    }

    /// Coefficients `b` fitted on [`Hold::apply`]'s regressors with each
    /// hold's weight set to minus its tied features' sum.
    pub(crate) fn tie(holds: &[Hold], mut b: Vec<f64>) -> Vec<f64> {
        for h in holds {
            b[h.feature] = -h.tied.iter().map(|&j| b[j]).sum::<f64>();
        }
        b
    }

    /// A row's regressors with the tied features taken relative to the
    /// hold and the hold's own column zero.
    pub(crate) fn apply(holds: &[Hold], mut row: Vec<f64>) -> Vec<f64> {
        for h in holds {
            let x0 = row[h.feature];
            for &j in &h.tied {
                row[j] -= x0;
            }
            row[h.feature] = 0.0;
        }
        row
    }
}

pub(crate) fn linear_eq(model: &Model, k: usize) -> Option<&LinearOutput> {
    match &model.params {
        Params::Linear(l) => l.outputs.iter().find(|e| usize::from(e.output) == k),
        _ => None,
    }
}

pub(crate) fn pcr_eq(model: &Model, k: usize) -> Option<(&Pcr, &PcrOutput)> {
    match &model.params {
        Params::Pcr(p) => p
            .outputs
            .iter()
            .find(|e| usize::from(e.output) == k)
            .map(|e| (p, e)),
        _ => None,
    }
}

/// Output `k` of a linear or PCR model: its regressors as a function of
/// the model-form inputs, and its old coefficients.
pub(crate) fn static_equation(model: &Model, k: usize) -> Result<(RegressorFn, Coefs)> {
    if let Some(eq) = linear_eq(model, k) {
        if eq.position.is_some() {
            bail!("refit does not update positional (slope) regressions");
        }
        let ch: Vec<usize> = eq.coef.iter().map(|c| usize::from(c.channel)).collect();
        Ok((
            Box::new(move |x: &[f64]| ch.iter().map(|&c| x[c]).collect()),
            (eq.intercept, eq.coef.iter().map(|c| c.value).collect()),
        ))
    } else if let Some((pcr, eq)) = pcr_eq(model, k) {
        if eq.position.is_some() {
            bail!("refit does not update positional (slope) regressions");
        }
        // The components stay; the regression on them is updated.
        let (pcr, used) = (pcr.clone(), eq.beta.len());
        Ok((
            Box::new(move |x: &[f64]| pcr.scores(x)[..used].to_vec()),
            (eq.intercept, eq.beta.to_vec()),
        ))
    } else {
        bail!("output #{k} has no equation");
    }
}

/// Every output's [`Structure`] of a linear or PCR model over the new runs.
pub(crate) fn static_structures(old: &ValidModel, runs: &[RunFile]) -> Result<Vec<Structure>> {
    let xs: Vec<Vec<Option<Vec<f64>>>> = runs
        .iter()
        .map(|r| model_inputs(old, r))
        .collect::<Result<_>>()?;
    (0..old.outputs().len())
        .map(|k| {
            let (phi, old_c) = static_equation(old.model(), k)?;
            let regs: Regressors = xs
                .iter()
                .map(|run| run.iter().map(|x| x.as_deref().map(&phi)).collect())
                .collect();
            Ok(Structure {
                regs: Rc::new(regs),
                old: old_c,
                tf_entries: None,
                holds: Vec::new(),
            })
        })
        .collect()
}

/// A one-output model of `params` over the old model's inputs, run alone
/// on each run through the runner (resampling and state exactly as the
/// whole model runs): `[run][row]`.
fn alone(
    old: &ValidModel,
    params: Params,
    output: u8,
    runs: &[RunFile],
) -> Result<Vec<Vec<Option<f64>>>> {
    let model = old.model();
    let name = old
        .outputs()
        .get(usize::from(output))
        .cloned()
        .ok_or_else(|| anyhow!("a part names a missing output"))?;
    let mut outputs = heapless::Vec::new();
    let _ = outputs.push(name);
    let m = Model {
        inputs: model.inputs.clone(),
        outputs,
        dt_s: model.dt_s,
        params,
        bounds: None,
        five_point: None,
    }
    .validate()
    .map_err(|e| anyhow!("model part: {e}"))?;
    let map = ColumnMap::default();
    runs.iter()
        .map(|r| Ok(runner::predict(&m, r, &map)?.values.swap_remove(0)))
        .collect()
}

/// Each TF entry simulated alone on each run: `[entry][run][row]`.
pub(crate) fn tf_entry_series(
    old: &ValidModel,
    entries: &[TfEntry],
    runs: &[RunFile],
) -> Result<Vec<Vec<Vec<Option<f64>>>>> {
    entries
        .iter()
        .map(|entry| {
            let mut single = entry.clone();
            single.output = 0;
            let mut ents = heapless::Vec::new();
            let _ = ents.push(single);
            alone(old, Params::Tf(ents), entry.output, runs)
        })
        .collect()
}

/// Each filter-bank feature alone on each run (a bank of that one feature
/// with weight 1), the filter state exactly as the whole model runs it:
/// `[feature][run][row]`.
fn fbank_feature_series(
    old: &ValidModel,
    bank: &FilterBank,
    runs: &[RunFile],
) -> Result<Vec<Vec<Vec<Option<f64>>>>> {
    bank.features
        .iter()
        .map(|f| {
            let mut features = heapless::Vec::new();
            let _ = features.push(*f);
            let mut coef = heapless::Vec::new();
            let _ = coef.push(1.0);
            let mut outputs = heapless::Vec::new();
            let _ = outputs.push(FbOutput {
                output: 0,
                intercept: 0.0,
                coef,
            });
            alone(
                old,
                Params::Fbank(FilterBank { features, outputs }),
                0,
                runs,
            )
        })
        .collect()
}

/// Every output's [`Structure`] of a filter bank: the features (shared by
/// every output) as regressors, taken relative to the output's holds
/// ([`Hold`]), the old intercept and weights.
fn fbank_structures(
    old: &ValidModel,
    bank: &FilterBank,
    runs: &[RunFile],
) -> Result<Vec<Structure>> {
    let shared: Rc<Regressors> = {
        let series = fbank_feature_series(old, bank, runs)?;
        Rc::new(
            runs.iter()
                .enumerate()
                .map(|(ri, run)| {
                    (0..run.len())
                        .map(|row| series.iter().map(|f| f[ri][row]).collect())
                        .collect()
                })
                .collect(),
        )
    };
    (0..old.outputs().len())
        .map(|k| {
            let eq = bank
                .outputs
                .iter()
                .find(|e| usize::from(e.output) == k)
                .ok_or_else(|| anyhow!("output #{k} has no equation"))?;
            Ok(Structure {
                regs: Rc::clone(&shared),
                holds: Hold::of(bank, eq, old.fbank_poles()),
                old: (eq.intercept, eq.coef.to_vec()),
                tf_entries: None,
            })
        })
        .collect()
}

/// Every output's [`Structure`] of a TF bank: its entries' simulated
/// outputs as regressors, a gain per entry (old gains 1).
pub(crate) fn tf_structures(
    old: &ValidModel,
    entries: &[TfEntry],
    runs: &[RunFile],
) -> Result<Vec<Structure>> {
    let series = tf_entry_series(old, entries, runs)?;
    Ok((0..old.outputs().len())
        .map(|k| {
            let idx: Vec<usize> = entries
                .iter()
                .enumerate()
                .filter(|(_, e)| usize::from(e.output) == k)
                .map(|(i, _)| i)
                .collect();
            let regs: Regressors = runs
                .iter()
                .enumerate()
                .map(|(ri, run)| {
                    (0..run.len())
                        .map(|row| idx.iter().map(|&e| series[e][ri][row]).collect())
                        .collect()
                })
                .collect();
            Structure {
                regs: Rc::new(regs),
                old: (0.0, vec![1.0; idx.len()]),
                tf_entries: Some(idx),
                holds: Vec::new(),
            }
        })
        .collect())
}

/// Builds every output's [`Structure`] over the new runs.
pub(crate) fn structures(old: &ValidModel, runs: &[RunFile]) -> Result<Vec<Structure>> {
    match &old.model().params {
        Params::Linear(_) | Params::Pcr(_) => static_structures(old, runs),
        Params::Tf(entries) => tf_structures(old, entries, runs),
        Params::Fbank(bank) => fbank_structures(old, bank, runs),
        _ => bail!(
            "refit updates linear, pcr, tf and fbank models; this is a {} model",
            old.kind().name()
        ),
    }
}

/// The old model with the outputs in `new` (output index -> coefficients) replaced.
pub(crate) fn with_updates(
    old: &ValidModel,
    sts: &[Structure],
    new: &[(usize, Coefs)],
) -> Result<ValidModel> {
    let mut model = old.model().clone();
    // The calibration bounds (input envelope, error band) describe the old
    // coefficients on the old data; they are dropped here and carried over
    // the new runs by `bounds::carried` once the updates to keep are known.
    model.bounds = None;
    for (k, (b0, b)) in new {
        match &mut model.params {
            Params::Linear(l) => {
                for eq in l.outputs.iter_mut().filter(|e| usize::from(e.output) == *k) {
                    eq.intercept = *b0;
                    for (c, v) in eq.coef.iter_mut().zip(b) {
                        c.value = *v;
                    }
                }
            }
            Params::Pcr(p) => {
                for eq in p.outputs.iter_mut().filter(|e| usize::from(e.output) == *k) {
                    eq.intercept = *b0;
                    for (c, v) in eq.beta.iter_mut().zip(b) {
                        *c = *v;
                    }
                }
            }
            Params::Fbank(bank) => {
                for eq in bank
                    .outputs
                    .iter_mut()
                    .filter(|e| usize::from(e.output) == *k)
                {
                    eq.intercept = *b0;
                    for (c, v) in eq.coef.iter_mut().zip(b) {
                        *c = *v;
                    }
                }
            }
            Params::Tf(entries) => {
                let idx = sts[*k].tf_entries.as_deref().unwrap_or(&[]);
                for (&e, g) in idx.iter().zip(b) {
                    if let Some(entry) = entries.get_mut(e) {
                        for a in entry.a.iter_mut() {
                            *a *= g;
                        }
                    }
                }
            }
            _ => bail!("cannot update a {} model", old.kind().name()),
        }
    }
    model
        .validate()
        .map_err(|e| anyhow!("the updated model is invalid ({e}); the old one is kept"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use model_core::fbank::{Feature, HOLD_TAU_S};

    /// T1 raw, T1 filtered at 15 min, T1 held; one output with `coef`.
    fn bank(coef: &[f64]) -> (FilterBank, [f64; 3]) {
        let feature = |tau_s| Feature {
            input: 0,
            power: 1,
            tau_s,
        };
        let bank = FilterBank {
            features: heapless::Vec::from_slice(&[
                feature(0.0),
                feature(900.0),
                feature(HOLD_TAU_S),
            ])
            .unwrap(),
            outputs: heapless::Vec::from_slice(&[FbOutput {
                output: 0,
                intercept: 0.0,
                coef: heapless::Vec::from_slice(coef).unwrap(),
            }])
            .unwrap(),
        };
        (bank, [0.0, 0.9, 1.0])
    }

    /// A hold weighed as minus its channel's other weights (to the rounding
    /// of their sum) is tied; one weighed freely stays a free column.
    #[test]
    fn only_a_hold_the_old_weights_tie_is_tied() {
        let tied = [0.3, 1.7, -(0.3 + 1.7)];
        let (b, poles) = bank(&tied);
        let holds = Hold::of(&b, &b.outputs[0], &poles);
        assert_eq!(holds.len(), 1);
        assert_eq!((holds[0].feature, holds[0].tied.clone()), (2, vec![0, 1]));
        let free = [0.3, 1.7, 5.0];
        let (b, poles) = bank(&free);
        assert!(Hold::of(&b, &b.outputs[0], &poles).is_empty());
        // Off by 1e-6 relative: beyond rounding, so free as well.
        let near = [0.3, 1.7, -2.0 * (1.0 + 1e-6)];
        let (b, poles) = bank(&near);
        assert!(Hold::of(&b, &b.outputs[0], &poles).is_empty());
    }
}
