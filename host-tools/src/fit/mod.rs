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
pub mod quiet;
pub mod tfbank;

pub use job::{fit, FitOptions, FitOutcome, FitParams, FitReport, ValidFitParams};

use crate::data::dataset::Dataset;
use anyhow::{anyhow, Result};
use model_core::model::{Name, MAX_CHANNELS, MAX_OUTPUTS};
use model_core::{Channel, ValidModel};
use serde::Serialize;

/// Model kinds `fit` trains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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

/// Columns `auto` reads besides the temperatures when the runs have them.
pub const AUTO_EXTRA_INPUTS: [&str; 4] = ["speed_rpm", "power_kw", "ambient_c", "coolant_c"];

/// What a kind's trainer returns.
pub struct Fitted {
    /// The validated model, ready to encode.
    pub model: ValidModel,
    /// Kind-specific figures (`details` in `fit --json`).
    pub details: Details,
}

/// A trainer's kind-specific figures: one typed report per trainer, each
/// beside its trainer. Serialised without a tag (`details` in `fit --json`
/// is the report's object itself); each report's fields are declared in
/// the JSON's key order, which is alphabetical (serde_json without
/// `preserve_order`, as every `--json` is printed through a `Value`).
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum Details {
    /// `auto`: the cross-validated choice of form, features and family.
    Auto(Box<auto::AutoReport>),
    /// `mlr`: one least-squares equation per target.
    Mlr(mlr::MlrDetails),
    /// `pcr`: the components kept and each target's regression on them.
    Pcr(pcr::PcrDetails),
    /// `arx`: the order and ridge search and the chosen equations.
    Arx(Box<arx::ArxDetails>),
    /// `tf`: the per-input order search and each SISO TF.
    Tf(Box<tfbank::TfDetails>),
    /// `gain`: the fitted gain and the scores of the model before it.
    Gain(gain::GainDetails),
    /// `bp` and `gabp`: the net, its training and (gabp) the GA.
    Bp(Box<bp::report::BpDetails>),
    /// `arma`: ADF tests, the AIC table, the chosen ARMA and its forecasts.
    Arma(Box<arma::report::ArmaDetails>),
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
