//! The `fit` job as a library call (linfa's shape): [`FitParams`] ->
//! [`FitParams::check`] -> [`ValidFitParams`] -> [`fit`] over runs in
//! memory -> [`FitOutcome`], whose [`FitReport`] serialises to the object
//! `fit --json` prints (less its `out`, the path the CLI wrote).

use super::{
    arma, arx, auto, bp, gain, mlr, pcr, tfbank, Details, FitKind, Fitted, AUTO_EXTRA_INPUTS,
};
use crate::data::cells::Level;
use crate::data::dataset::{Dataset, InputForm};
use crate::data::runfile::{ReadOptions, RowStream, RunFile};
use crate::score::{score, TargetScore};
use anyhow::{anyhow, bail, Result};
use model_core::ValidModel;
use serde::Serialize;
use std::collections::BTreeMap;

use crate::score::TargetReport;

/// Every kind's training options; [`Default`] is `thermcomp fit`'s
/// defaults (the CLI's flag groups convert into it, `cli::fit`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FitOptions {
    /// PCR options.
    pub pcr: pcr::PcrOptions,
    /// ARX, TF, gain (and auto/arma `dt_s`) options.
    pub arx: super::dynamic::options::DynamicOptions,
    /// BP and GA-BP options.
    pub bp: bp::BpOptions,
    /// ARMA options.
    pub arma: arma::ArmaOptions,
    /// Auto options.
    pub auto: auto::AutoOptions,
}

impl FitOptions {
    /// Checks the options of `kind` that need no data (sizes against the
    /// inputs and rows are the trainers' to check, against the dataset).
    pub fn check(&self, kind: FitKind) -> Result<()> {
        match kind {
            FitKind::Pcr => self.pcr.check(),
            FitKind::Arx | FitKind::Tf => self.arx.check(kind),
            FitKind::Arma => self.arma.check(),
            _ => Ok(()),
        }
    }
}

/// What to fit: targets, inputs, kind, split and options.
#[derive(Clone, Debug)]
pub struct FitParams {
    /// Target columns (model outputs).
    pub targets: Vec<String>,
    /// Input columns; empty: every `T<n>` of the first run (with `auto` also
    /// [`AUTO_EXTRA_INPUTS`] present), less the targets.
    pub inputs: Vec<String>,
    /// The model kind.
    pub kind: FitKind,
    /// Hold out every row at or after this time (s) of each calibration run.
    pub holdout_from_s: Option<f64>,
    /// How inputs enter the model (ignored by `auto` and `arma`: absolute).
    pub reference: InputForm,
    /// Five-point geometry: the deflection-centre distance, mm, recorded
    /// when the targets are `e_um`, `theta_x_urad`, `theta_y_urad`
    /// (default [`crate::fivepoint`]'s); refused for other targets.
    pub l_defl_mm: Option<f64>,
    /// Kind-specific options.
    pub options: FitOptions,
}

/// [`FitParams`] that passed [`FitParams::check`].
#[derive(Clone, Debug)]
pub struct ValidFitParams {
    params: FitParams,
    form: InputForm,
}

impl FitParams {
    /// Checks what can be checked without data: one target at least; arma
    /// forecasts one target from itself; no target among the inputs; the
    /// kind's options ([`FitOptions::check`]). The holdout time is judged
    /// against the runs, by [`Dataset::new`].
    pub fn check(&self) -> Result<ValidFitParams> {
        if self.targets.is_empty() {
            bail!("a fit needs at least one --target column");
        }
        let arma = self.kind == FitKind::Arma;
        if arma && (self.targets.len() != 1 || !self.inputs.is_empty()) {
            bail!("arma: give one --target (the series it forecasts) and no --inputs");
        }
        if let Some(t) = self.targets.iter().find(|t| self.inputs.contains(t)) {
            bail!("{t} is both a --target and one of the --inputs: a model cannot read what it predicts");
        }
        for (flag, names) in [("--target", &self.targets), ("--inputs", &self.inputs)] {
            if let Some((first, again)) = first_repeat(names) {
                bail!(
                    "{flag} names {} twice (positions {} and {})",
                    names[again],
                    first + 1,
                    again + 1
                );
            }
        }
        if let Some(h) = self.holdout_from_s.filter(|h| !h.is_finite()) {
            bail!("--holdout-from-s {h}: give a time in seconds");
        }
        self.options.check(self.kind)?;
        let form = if arma || self.kind == FitKind::Auto {
            InputForm::Absolute
        } else {
            self.reference
        };
        Ok(ValidFitParams {
            params: self.clone(),
            form,
        })
    }
}

impl ValidFitParams {
    /// The checked parameters.
    pub fn params(&self) -> &FitParams {
        &self.params
    }

    /// The columns a fit reads from run files (inputs, then targets);
    /// the calibration runs' files `data` are read for their headers only
    /// when the default inputs depend on them, and a column the first run
    /// has but another lacks is said on stderr (it is not a default input).
    pub fn columns_read(&self, data: &[std::path::PathBuf]) -> Result<Vec<String>> {
        let p = &self.params;
        let first = data.first().ok_or_else(|| anyhow!("no --data"))?;
        let inputs = if p.inputs.is_empty() && p.kind != FitKind::Arma {
            let header_only = ReadOptions {
                skip_bad_rows: false,
                only: Some(Vec::new()),
            };
            let heads = data
                .iter()
                .map(|d| {
                    let stream = RowStream::open(d, &header_only)?;
                    Ok((d.display().to_string(), stream.columns().to_vec()))
                })
                .collect::<Result<Vec<_>>>()?;
            let (common, missing) = common_columns(&heads);
            let inputs = self.inputs_for(&common, &first.display().to_string())?;
            let all = self.inputs_for(&heads[0].1, "")?;
            for (column, run) in missing.iter().filter(|(c, _)| all.contains(c)) {
                eprintln!("note: {column} is not in {run}: not among the default inputs");
            }
            inputs
        } else {
            self.inputs_for(&[], "")?
        };
        Ok(inputs.iter().chain(&p.targets).cloned().collect())
    }

    /// The inputs a fit on runs with `columns` reads (`source` names the
    /// first run in the error when no default input exists).
    pub fn inputs_for(&self, columns: &[String], source: &str) -> Result<Vec<String>> {
        let p = &self.params;
        if p.kind == FitKind::Arma {
            return Ok(p.targets.clone());
        }
        if !p.inputs.is_empty() {
            return Ok(p.inputs.clone());
        }
        let auto = p.kind == FitKind::Auto;
        let cols: Vec<String> = columns
            .iter()
            .filter(|c| {
                crate::data::runfile::is_temperature_column(c)
                    || (auto && AUTO_EXTRA_INPUTS.contains(&c.as_str()))
            })
            .cloned()
            .collect();
        if cols.is_empty() {
            bail!("{source}: no T<number> columns; name the inputs with --inputs");
        }
        Ok(cols
            .into_iter()
            .filter(|c| !p.targets.contains(c))
            .collect())
    }
}

/// `fit --json`'s object, less `out`.
#[derive(Clone, Debug, Serialize)]
pub struct FitReport {
    /// The kind of the model written (`auto` writes a `tf`, `arx` a `tf`, ...).
    pub model: String,
    /// Size of the blob, bytes.
    pub bytes: usize,
    /// The inputs the fit was given, in order (the blob may read fewer:
    /// auto's `details.quiet_inputs`, arx's forward selection; `model show`
    /// lists what it reads).
    pub inputs: Vec<String>,
    /// `change` or `absolute`.
    pub reference: String,
    /// As given.
    pub holdout_from_s: Option<f64>,
    /// Calibration rows used.
    pub calibration_rows: usize,
    /// Held-out rows (calibration runs' tails and validation runs).
    pub holdout_rows: usize,
    /// Rows the reader left out (`--skip-bad-rows`).
    pub skipped_rows: usize,
    /// Figures per target.
    pub targets: BTreeMap<String, TargetReport>,
    /// Five-point geometry recorded in the blob (docs/fivepoint.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub l_defl_mm: Option<f64>,
    /// Kind-specific figures (search tables, chosen orders, ...).
    pub details: Details,
}

/// What [`fit`] produced.
pub struct FitOutcome {
    /// The model decoded back from its blob (what is flashed).
    pub model: ValidModel,
    /// The blob's bytes.
    pub bytes: Vec<u8>,
    /// Calibration and held-out figures per target.
    pub scores: Vec<TargetScore>,
    /// The inputs the model reads, in order.
    pub inputs: Vec<String>,
    /// Inputs that did not move beyond their noise in the calibration rows
    /// and that the model weighs anyway (fit/quiet.rs; kinds other than
    /// auto, which leaves them out, and arma, which reads no input).
    pub unmoved: Vec<super::quiet::QuietInput>,
    /// Calibration rows used.
    pub calibration_rows: usize,
    /// The figures, serialisable.
    pub report: FitReport,
}

impl FitOutcome {
    /// The report of an `auto` fit (its CV tables and bands); `None` for
    /// the other kinds.
    pub fn auto_report(&self) -> Option<&super::auto::AutoReport> {
        match &self.report.details {
            super::Details::Auto(r) => Some(r),
            _ => None,
        }
    }
}

/// Trains on `runs` (calibration, with a held-out tail from
/// `holdout_from_s`) and scores on them and on `validate` (held out whole),
/// all in memory. The figures are those of the encoded blob, decoded back.
pub fn fit(p: &ValidFitParams, runs: &[RunFile], validate: &[RunFile]) -> Result<FitOutcome> {
    let first = runs.first().ok_or_else(|| anyhow!("no --data"))?;
    let heads: Vec<(String, Vec<String>)> = runs
        .iter()
        .map(|r| (r.path.display().to_string(), r.columns.clone()))
        .collect();
    let (common, _) = common_columns(&heads);
    let inputs = p.inputs_for(&common, &first.path.display().to_string())?;
    let a = &p.params;
    refuse_unprintable(inputs.iter().chain(&a.targets))?;
    let ds = Dataset::new(
        runs,
        validate,
        &inputs,
        &a.targets,
        p.form,
        a.holdout_from_s,
    )?;
    refuse_constant_targets(&ds)?;
    let unmoved = match a.kind {
        FitKind::Auto | FitKind::Arma => Vec::new(),
        _ => super::quiet::quiet_inputs(&ds)
            .into_iter()
            .map(|(_, q)| q)
            .collect(),
    };
    let fitted = train(p, &ds, runs, validate)?;
    let model = crate::fivepoint::with_geometry(fitted.model, a.l_defl_mm)?;
    let bytes = model_core::blob::encode_to_vec(&model)
        .map_err(|e| anyhow!("cannot encode the model: {e}"))?;
    // Score what is flashed, decoded back: the figures are the blob's.
    let flashed = model_core::decode(&bytes).map_err(|e| anyhow!("written blob: {e}"))?;
    let split = ds.scoring_split(runs, validate);
    let scores = score(&flashed, &split)?;
    let report = FitReport {
        model: flashed.kind().name().to_string(),
        bytes: bytes.len(),
        inputs: ds.inputs.clone(),
        reference: ds.form.name().to_string(),
        holdout_from_s: a.holdout_from_s,
        calibration_rows: ds.calibration_len(),
        holdout_rows: ds.holdout_len(),
        skipped_rows: crate::data::source::skipped_rows(runs.iter().chain(validate)),
        targets: scores
            .iter()
            .map(|t| (t.output.clone(), TargetReport::from(t)))
            .collect(),
        l_defl_mm: flashed.five_point().map(|t| t.l_defl_mm()),
        details: fitted.details,
    };
    Ok(FitOutcome {
        model: flashed,
        bytes,
        scores,
        calibration_rows: report.calibration_rows,
        inputs: ds.inputs,
        unmoved,
        report,
    })
}

/// The columns every run has (`runs`: each run's name and columns), in
/// the first run's order, and each column of the first run that another
/// lacks, with that run's name (the first such).
pub fn common_columns(runs: &[(String, Vec<String>)]) -> (Vec<String>, Vec<(String, String)>) {
    let Some(((_, first), rest)) = runs.split_first() else {
        return (Vec::new(), Vec::new());
    };
    let mut common = Vec::new();
    let mut missing = Vec::new();
    for c in first {
        match rest.iter().find(|(_, cols)| !cols.contains(c)) {
            Some((name, _)) => missing.push((c.clone(), name.clone())),
            None => common.push(c.clone()),
        }
    }
    (common, missing)
}

/// Refuses a column a model would name with a control character in it (a
/// line break, an escape sequence: `model show` would print it raw), before
/// the fit runs: model-core refuses such a blob (`ModelError::ControlInName`).
fn refuse_unprintable<'a>(names: impl IntoIterator<Item = &'a String>) -> Result<()> {
    match names.into_iter().find(|n| n.chars().any(char::is_control)) {
        Some(n) => bail!(
            "column name {n:?} holds a control character: a model's column names must be printable"
        ),
        None => Ok(()),
    }
}

/// Refuses a target that never moves over the calibration rows: there is
/// nothing to fit, and every score of it would be 0/0 (arma and `select`
/// refuse it as well).
fn refuse_constant_targets(ds: &Dataset) -> Result<()> {
    let mut levels = vec![Level::Empty; ds.targets.len()];
    ds.visit_calibration_rows(&mut |_, y| {
        for (l, v) in levels.iter_mut().zip(y) {
            *l = l.push(*v);
        }
    });
    // No calibration row at all is refused by `Dataset::new`.
    for (t, l) in ds.targets.iter().zip(levels) {
        if let Level::Flat(v) = l {
            bail!(
                "{t} is constant ({v}) on every calibration row: nothing to fit (check the \
                 column and --holdout-from-s)"
            );
        }
    }
    Ok(())
}

/// The positions of the first name that repeats an earlier one, and of
/// that earlier one.
fn first_repeat(names: &[String]) -> Option<(usize, usize)> {
    names
        .iter()
        .enumerate()
        .find_map(|(i, n)| names[..i].iter().position(|m| m == n).map(|j| (j, i)))
}

/// Refuses more inputs than the hub reads before any work, naming the way
/// out (`kind`: the trainer's name in the message).
pub fn within_hub(kind: &str, ds: &Dataset) -> Result<()> {
    use model_core::model::MAX_CHANNELS;
    let n = ds.inputs.len();
    if n > MAX_CHANNELS {
        bail!(
            "{kind}: {n} inputs, but the hub reads at most {MAX_CHANNELS}: name at most \
             {MAX_CHANNELS} with --inputs (`thermcomp select` ranks the temperatures)"
        );
    }
    Ok(())
}

/// The kind's trainer on `ds`.
fn train(
    p: &ValidFitParams,
    ds: &Dataset,
    runs: &[RunFile],
    validate: &[RunFile],
) -> Result<Fitted> {
    let o = &p.params.options;
    // The static kinds read every input on one channel each: more than the
    // hub's are refused before training (auto checks in its own params;
    // arx and tf have their bank's smaller limit).
    let static_kind = match p.params.kind {
        FitKind::Mlr => Some("mlr"),
        FitKind::Pcr => Some("pcr"),
        FitKind::Bp => Some("bp"),
        FitKind::Gabp => Some("gabp"),
        _ => None,
    };
    if let Some(kind) = static_kind {
        within_hub(kind, ds)?;
    }
    match p.params.kind {
        FitKind::Auto => {
            let params = auto::AutoParams {
                folds: o.auto.auto_folds,
                ensemble: o.auto.auto_ensemble,
                dt_s: o.arx.dt_s,
                eliminate: o.auto.auto_eliminate,
                families: o.auto.auto_families.clone(),
            };
            auto::fit(ds, &params.check(ds)?)
        }
        FitKind::Mlr => mlr::fit(ds),
        FitKind::Pcr => pcr::fit(ds, &o.pcr),
        FitKind::Arx => arx::fit(ds, &o.arx),
        FitKind::Tf => tfbank::fit(ds, &o.arx),
        FitKind::Gain => gain::fit(ds, &o.arx, runs, validate),
        FitKind::Bp => bp::fit(ds, &o.bp, false),
        FitKind::Gabp => bp::fit(ds, &o.bp, true),
        FitKind::Arma => arma::fit(ds, &o.arma, o.arx.dt_s),
    }
}
