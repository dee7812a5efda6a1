//! Re-use of a TF-bank model on another machine or spindle unit by fitting
//! one gain (seed 004, Sec. 3.2, Eq. 6: `dZ = g (dT_bearing eps_SP1) +
//! dT_amb eps_amb`).
//!
//! The existing blob is run, exactly as the hub runs it, over the
//! calibration rows, split into its scaled part `s` (entries whose input is
//! in `--gain-inputs`; by default every input but `ambient_c`, seed 004's
//! spindle part) and the rest `r`. The gain is the least-squares solution of
//! `y - r = g s` over every output and calibration row,
//! `g = sum s (y - r) / sum s^2`, and the scaled model multiplies the
//! numerators of those entries by `g` (poles, hence time constants, stay).

use super::dynamic::options::DynamicOptions;
use super::{Details, Fitted};
use crate::data::dataset::Dataset;
use crate::data::runfile::RunFile;
use crate::runner::{self, ColumnMap};
use crate::score::{score, TargetReport};
use anyhow::{anyhow, bail, Result};
use model_core::{Model, Params, ValidModel};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// The input `seed 004` does not scale.
const AMBIENT: &str = "ambient_c";

/// What `gain` reports (fields in the JSON's key order).
#[derive(Clone, Debug, Serialize)]
pub struct GainDetails {
    /// Per target, the scores of the model before scaling (`--gain-from` as is).
    pub before: BTreeMap<String, TargetReport>,
    /// Calibration samples (over every output) the gain was fitted on.
    pub calibration_samples: usize,
    /// Every TF entry of the model and whether the gain scales it.
    pub entries: Vec<GainEntry>,
    /// The blob scaled (`--gain-from`).
    pub from: String,
    /// The fitted gain `g` (dimensionless).
    pub gain: f64,
    /// Inputs whose entries are scaled.
    pub scaled_inputs: Vec<String>,
}

/// One TF entry of the scaled model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GainEntry {
    /// Its input.
    pub input: String,
    /// Its output.
    pub output: String,
    /// Whether its numerator is multiplied by the gain.
    pub scaled: bool,
}

/// `model` with the numerators of entries where `keep(entry index)` is false
/// set to zero (entries stay, so every output keeps an entry).
fn part(model: &ValidModel, keep: &dyn Fn(usize) -> bool) -> Result<ValidModel> {
    let mut m: Model = model.model().clone();
    if let Params::Tf(entries) = &mut m.params {
        for (e, en) in entries.iter_mut().enumerate() {
            if !keep(e) {
                en.a.iter_mut().for_each(|c| *c = 0.0);
            }
        }
    }
    m.validate().map_err(|e| anyhow!("part of the model: {e}"))
}

/// The model `path` reads only inputs the dataset has and computes only
/// its targets.
fn check_matches(ds: &Dataset, old: &ValidModel, names: &[String], path: &Path) -> Result<()> {
    for n in names {
        if !ds.inputs.contains(n) {
            bail!(
                "{}: the model reads {n}; pass --inputs {} (the model's inputs)",
                path.display(),
                names.join(",")
            );
        }
    }
    for o in old.outputs() {
        if !ds.targets.iter().any(|t| t == o.as_str()) {
            bail!(
                "{}: the model computes {o}; pass it in --target",
                path.display()
            );
        }
    }
    Ok(())
}

/// The inputs whose entries the gain scales: `--gain-inputs` (each an input
/// of the model), or every input but [`AMBIENT`].
fn gain_inputs(args: &DynamicOptions, names: &[String], path: &Path) -> Result<Vec<String>> {
    if args.gain_inputs.is_empty() {
        return Ok(names.iter().filter(|n| *n != AMBIENT).cloned().collect());
    }
    for n in &args.gain_inputs {
        if !names.contains(n) {
            bail!(
                "--gain-inputs {n}: not an input of {} ({})",
                path.display(),
                names.join(", ")
            );
        }
    }
    Ok(args.gain_inputs.clone())
}

/// The least-squares gain `g = sum s (y - r) / sum s^2` of the scaled part
/// `spindle` given the rest, over every output and calibration row; and
/// the number of samples.
fn least_squares_gain(
    ds: &Dataset,
    runs: &[RunFile],
    old: &ValidModel,
    (spindle, rest): (&ValidModel, &ValidModel),
) -> Result<(f64, usize)> {
    let map = ColumnMap::default();
    let (mut sxy, mut sxx, mut n) = (0.0, 0.0, 0usize);
    for (run, data) in runs.iter().zip(&ds.runs) {
        let s = runner::predict(spindle, run, &map)?;
        let r = runner::predict(rest, run, &map)?;
        for (k, name) in old.outputs().iter().enumerate() {
            let y = run
                .column(name)
                .ok_or_else(|| anyhow!("{}: no column \"{name}\"", run.path.display()))?;
            for row in 0..data.calib_end.min(y.len()) {
                if let (Some(y), Some(s), Some(r)) =
                    (y.get(row), s.values[k][row], r.values[k][row])
                {
                    sxy += s * (y - r);
                    sxx += s * s;
                    n += 1;
                }
            }
        }
    }
    if n == 0 || sxx == 0.0 {
        bail!("--model gain: the scaled part of the model is zero on every calibration row: no gain can be fitted");
    }
    Ok((sxy / sxx, n))
}

/// `old` with the numerators of the `scaled` entries multiplied by `g`.
fn scaled_model(old: &ValidModel, scaled: &[bool], g: f64) -> Result<ValidModel> {
    let mut m = old.model().clone();
    if let Params::Tf(entries) = &mut m.params {
        for (en, s) in entries.iter_mut().zip(scaled) {
            if *s {
                en.a.iter_mut().for_each(|c| *c *= g);
            }
        }
    }
    m.validate()
        .map_err(|e| anyhow!("scaled model refused: {e}"))
}

/// Fits `--model gain`.
pub fn fit(
    ds: &Dataset,
    args: &DynamicOptions,
    runs: &[RunFile],
    validate: &[RunFile],
) -> Result<Fitted> {
    let path = args
        .gain_from
        .as_ref()
        .ok_or_else(|| anyhow!("--model gain needs --gain-from MODEL.bin"))?;
    let (old, _) = crate::data::blobfile::read(path)?;
    let Params::Tf(entries) = &old.model().params else {
        bail!(
            "{}: a {} model; --gain-from needs a TF bank (kind tf)",
            path.display(),
            old.kind().name()
        );
    };
    let names: Vec<String> = old.inputs().iter().map(|c| c.name.to_string()).collect();
    check_matches(ds, &old, &names, path)?;
    let scaled_inputs = gain_inputs(args, &names, path)?;
    let scaled: Vec<bool> = entries
        .iter()
        .map(|e| scaled_inputs.contains(&names[usize::from(e.input)]))
        .collect();
    if !scaled.iter().any(|s| *s) {
        bail!("--model gain: no entry of the model has an input in {scaled_inputs:?}");
    }
    let spindle = part(&old, &|e| scaled[e])?;
    let rest = part(&old, &|e| !scaled[e])?;
    let (g, n) = least_squares_gain(ds, runs, &old, (&spindle, &rest))?;
    let model = scaled_model(&old, &scaled, g)?;
    let split = ds.scoring_split(runs, validate);
    let before = score(&old, &split)?
        .iter()
        .map(|t| (t.output.clone(), TargetReport::from(t)))
        .collect();
    eprintln!(
        "gain: g = {g:.6} on the entries of {} ({n} calibration samples)",
        scaled_inputs.join(", ")
    );
    let entries = entries
        .iter()
        .zip(&scaled)
        .map(|(e, s)| GainEntry {
            input: names[usize::from(e.input)].clone(),
            output: old.outputs()[usize::from(e.output)].as_str().to_string(),
            scaled: *s,
        })
        .collect();
    let details = GainDetails {
        before,
        calibration_samples: n,
        entries,
        from: path.display().to_string(),
        gain: g,
        scaled_inputs,
    };
    Ok(Fitted {
        model,
        details: Details::Gain(details),
    })
}
