//! `thermcomp fit`: trains a model on calibration rows, scores it on
//! held-out rows, and writes the blob.
//!
//! Each kind lives in its own module and turns a [`Dataset`] into a
//! [`Fitted`] model; this module reads the runs, splits them, writes the
//! blob, and scores the model with the same runner `predict` and `eval` use
//! (through the encoded blob, so the figures are those of what is flashed).

pub mod arma;
pub mod arx;
pub mod auto;
pub mod bp;
pub mod dynamic;
pub mod gain;
pub mod job;
pub mod mlr;
pub mod pcr;
pub mod tfbank;

pub use job::{fit, FitOptions, FitOutcome, FitParams, FitReport, ValidFitParams};

use crate::data::dataset::{Dataset, InputForm};
use crate::data::runfile::{ReadOptions, RunFile};
use crate::score::TargetScore;
use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
use model_core::model::{Name, MAX_CHANNELS, MAX_OUTPUTS};
use model_core::{Channel, ValidModel};
use serde_json::Value;
use std::path::PathBuf;

/// Model kinds `fit` trains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FitKind {
    /// Input form, filter-bank features, penalty and filter time constants
    /// chosen per target by time-respecting cross-validation on the
    /// calibration data (a ridge over low-pass filters: a TF bank the hub
    /// runs); PCR, ARX, TF and BP weighed on the same folds, one taking its
    /// place only when its CV error is lower beyond noise (--auto-families).
    Auto,
    /// Multiple linear regression (least squares by SVD).
    Mlr,
    /// Principal component regression (seed 003).
    Pcr,
    /// MISO ARX, order search by simulation fit, exported as a TF bank.
    Arx,
    /// Seed 004's TF bank: one SISO TF per input, fitted for simulation (output error).
    Tf,
    /// An existing TF bank (--gain-from) with its spindle part scaled by one fitted gain (seed 004, Eq. 6).
    Gain,
    /// One-hidden-layer BP network trained by Levenberg-Marquardt (seeds 000, 003).
    Bp,
    /// BP network whose hidden size and initial weights a genetic algorithm chooses (seed 000).
    Gabp,
    /// ARMA forecaster of the target series itself (seed 001): ADF, differencing, AIC order.
    Arma,
}

/// Arguments of `thermcomp fit`.
#[derive(Args)]
pub struct FitArgs {
    /// A calibration run (CSV); repeatable. Each run restarts a dynamic model's state.
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// A validation run, held out whole (repeatable).
    #[arg(long)]
    pub validate: Vec<PathBuf>,
    /// Target column(s), comma-separated (e.g. ch1_um or dx_um,dz_um).
    #[arg(long, value_delimiter = ',', required = true)]
    pub target: Vec<String>,
    /// Input columns, comma-separated (default: every column named T<number>;
    /// with `auto` also speed_rpm, power_kw, ambient_c and coolant_c where present).
    #[arg(long, value_delimiter = ',')]
    pub inputs: Vec<String>,
    /// The model kind.
    #[arg(long, value_enum)]
    pub model: FitKind,
    /// Where to write the model blob.
    #[arg(long)]
    pub out: PathBuf,
    /// Hold out every row at or after this time (s) of each --data run.
    #[arg(long, value_name = "SECONDS")]
    pub holdout_from_s: Option<f64>,
    /// How inputs enter the model: "change" from each run's first sample
    /// (default: cancels day-to-day offsets of absolute temperature), or "absolute".
    #[arg(long, value_enum, default_value = "change")]
    pub reference: InputForm,
    /// Skip rows with unparsable cells instead of failing (they are counted and reported).
    #[arg(long)]
    pub skip_bad_rows: bool,
    /// Print one JSON object with the fit and held-out figures.
    #[arg(long)]
    pub json: bool,
    /// Five-point targets (e_um,theta_x_urad,theta_y_urad): the spindle's
    /// deflection centre above the nose, mm, recorded in the blob so that the
    /// hub turns the outputs into tool-tip offsets (default 300, the twin's
    /// machine; docs/fivepoint.md).
    #[arg(long, value_name = "MM")]
    pub l_defl_mm: Option<f64>,
    /// Every kind's training options (the job's own struct: one source of
    /// their flags, defaults and checks).
    #[command(flatten)]
    pub options: FitOptions,
}

/// Options of `--model auto`.
#[derive(Args, Clone, Debug)]
pub struct AutoArgs {
    /// auto: contiguous cross-validation folds within a single calibration
    /// run (several runs: one fold per run).
    #[arg(long, default_value_t = 6)]
    pub auto_folds: usize,
    /// auto: how many of the best candidates the model averages (as many
    /// as fit the hub's 128 features; 20 won on the development split,
    /// scripts/auto_dev_split.sh).
    #[arg(long, default_value_t = 20)]
    pub auto_ensemble: usize,
    /// auto: how many of the best candidates also try dropping temperature
    /// sensors (backward elimination by CV, one-standard-error rule; 0: off,
    /// the default: on the development split it lost more than it won,
    /// docs/validation-auto.md).
    #[arg(long, default_value_t = 0)]
    pub auto_eliminate: usize,
    /// auto: model families weighed by the same cross-validation: ridge
    /// (the filter bank, always), pcr, arx, tf, bp, gabp. Another family
    /// replaces the ridge only when its CV error is lower beyond noise;
    /// "ridge" alone: the filter bank only.
    #[arg(long, value_delimiter = ',', default_value = auto::family::DEFAULT_FAMILIES, value_name = "LIST")]
    pub auto_families: Vec<String>,
}

/// Columns `auto` reads besides the temperatures when the runs have them.
pub const AUTO_EXTRA_INPUTS: [&str; 4] = ["speed_rpm", "power_kw", "ambient_c", "coolant_c"];

/// What a kind's trainer returns.
pub struct Fitted {
    /// The validated model, ready to encode.
    pub model: ValidModel,
    /// Kind-specific figures for the JSON (`details`).
    pub details: Value,
}

/// Model input channels for `ds`'s inputs in its form.
pub fn channels(ds: &Dataset) -> Result<heapless::Vec<Channel, MAX_CHANNELS>> {
    let mut out = heapless::Vec::new();
    for name in &ds.inputs {
        out.push(Channel {
            name: Name::try_from(name.as_str())
                .map_err(|_| anyhow!("input name \"{name}\" is too long"))?,
            reference: ds.form.reference(),
        })
        .map_err(|_| anyhow!("more than {MAX_CHANNELS} inputs"))?;
    }
    Ok(out)
}

/// Model output names for `ds`'s targets.
pub fn outputs(ds: &Dataset) -> Result<heapless::Vec<Name, MAX_OUTPUTS>> {
    let mut out = heapless::Vec::new();
    for name in &ds.targets {
        out.push(
            Name::try_from(name.as_str())
                .map_err(|_| anyhow!("target name \"{name}\" is too long"))?,
        )
        .map_err(|_| {
            anyhow!("{} targets: a model has at most {MAX_OUTPUTS} outputs (the hub sends dx, dy, dz and one more); fit the rest as another model", ds.targets.len())
        })?;
    }
    Ok(out)
}

fn scores_text(scores: &[TargetScore]) -> String {
    let mut s = format!(
        "{:<10} {:<12} {:>7} {:>9} {:>8} {:>8} {:>9} {:>9}\n",
        "target", "part", "n", "rmse_um", "fit_%", "r2", "dpk_um", "reduce_%"
    );
    for t in scores {
        for (part, m) in [("calibration", &t.calibration), ("held-out", &t.holdout)] {
            if let Some(m) = m {
                s.push_str(&format!(
                    "{:<10} {:<12} {:>7} {:>9.3} {:>8.2} {:>8.4} {:>9.3} {:>9.2}\n",
                    t.output, part, m.n, m.rmse, m.fit_pct, m.r2, m.dpk, m.reduction_pct
                ));
            }
        }
    }
    s
}

impl FitArgs {
    /// The job's parameters, from the flags.
    pub fn params(&self) -> FitParams {
        FitParams {
            targets: self.target.clone(),
            inputs: self.inputs.clone(),
            kind: self.model,
            holdout_from_s: self.holdout_from_s,
            reference: self.reference,
            l_defl_mm: self.l_defl_mm,
            options: self.options.clone(),
        }
    }
}

/// Reads the runs, [`fit`]s, writes the blob: everything `thermcomp fit`
/// does but print. `thermcomp demo` calls it too.
pub fn fit_files(a: &FitArgs) -> Result<FitOutcome> {
    let first = a.data.first().ok_or_else(|| anyhow!("no --data"))?;
    check_paths(a)?;
    let params = a.params().check()?;
    // Read only the columns the fit uses; the inputs default needs the header first.
    let header_only = ReadOptions {
        skip_bad_rows: true,
        only: Some(Vec::new()),
    };
    let inputs = if a.inputs.is_empty() && a.model != FitKind::Arma {
        let header = RunFile::read(first, &header_only)?;
        params.inputs_for(&header.columns, &first.display().to_string())?
    } else {
        params.inputs_for(&[], "")?
    };
    let needed: Vec<String> = inputs.iter().chain(&a.target).cloned().collect();
    let opts = ReadOptions {
        skip_bad_rows: a.skip_bad_rows,
        only: Some(needed),
    };
    let runs = crate::data::source::read_runs(&a.data, &opts)?;
    let validate = crate::data::source::read_runs(&a.validate, &opts)?;
    let outcome = fit(&params, &runs, &validate)?;
    crate::data::fsio::write_bytes_atomic(&a.out, &outcome.bytes)?;
    Ok(outcome)
}

/// `fit --json`'s object: the report and the path written.
pub fn report_json(o: &FitOutcome, out: &std::path::Path) -> Result<Value> {
    let mut v = serde_json::to_value(&o.report)?;
    if let Value::Object(m) = &mut v {
        m.insert("out".into(), Value::String(out.display().to_string()));
    }
    Ok(v)
}

/// Refuses an `--out` that is the same file as a `--data` or `--validate` run.
fn check_paths(a: &FitArgs) -> Result<()> {
    let data = a.data.iter().map(|p| crate::data::fsio::named("--data", p));
    let validate = a
        .validate
        .iter()
        .map(|p| crate::data::fsio::named("--validate", p));
    let reads: Vec<_> = data.chain(validate).collect();
    crate::data::fsio::check_distinct(&reads, &[crate::data::fsio::named("--out", &a.out)])
}

/// Runs `thermcomp fit`.
pub fn run(a: &FitArgs) -> Result<()> {
    let o = fit_files(a)?;
    if a.json {
        crate::data::fsio::print_line(&report_json(&o, &a.out)?.to_string())?;
    } else {
        crate::data::fsio::print(&scores_text(&o.scores))?;
        eprintln!(
            "wrote {} ({} bytes, {} model on {} inputs, {} calibration rows)",
            a.out.display(),
            o.bytes.len(),
            o.model.kind().name(),
            o.inputs.len(),
            o.calibration_rows
        );
    }
    Ok(())
}
