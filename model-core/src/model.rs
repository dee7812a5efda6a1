//! A compensation model: named inputs, named outputs, and one of the model
//! kinds, validated once and then run sample by sample.
//!
//! [`Model`] is the plain data a blob carries. [`Model::validate`] checks it
//! completely (indices, sizes, finiteness, TF stability) and returns a
//! [`ValidModel`], whose [`ValidModel::step`] cannot fail on the model's
//! account: it only refuses inputs that are not finite, and it never lets a
//! non-finite value into its state or out to the CNC. State lives apart from
//! the coefficients in a [`ModelState`], so the firmware can swap a new model
//! in without touching the running one.
//!
//! A model may also carry calibration [`Bounds`]: the input envelope it was
//! calibrated on and the 95 % band of its cross-validation error.
//! [`ValidModel::extrapolation`] says how far a sample lies outside the
//! envelope and [`ValidModel::band_half_width`] widens the band by that much.

use crate::arma::{Arma, ArmaState};
use crate::bp::BpNet;
use crate::fbank::{FilterBank, HOLD_TAU_S, MAX_FB_FEATURES};
use crate::fivepoint::{FivePoint, TipMap};
use crate::linear::Linear;
use crate::pcr::Pcr;
use crate::tf::{RealisedTf, TfEntry, TfError, TfHistory, MAX_TF_ENTRIES};
use serde::{Deserialize, Serialize};

pub use crate::capacity::{Name, MAX_CHANNELS, MAX_OUTPUTS, NAME_LEN};
pub use crate::error::ModelError;

/// Largest input magnitude `step` accepts. No quantity the hub reads
/// (temperature in C, speed in rpm, power in kW, position in mm, displacement
/// in um) comes near 1e9; a value beyond is a broken reading, and refusing it
/// keeps every model's state bounded (a finite but absurd sample could
/// otherwise overflow the next step's arithmetic for as long as it stays in
/// the history).
pub const MAX_INPUT_MAGNITUDE: f64 = 1e9;

/// What an input is measured against before it enters the model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Reference {
    /// The raw value (absolute temperature, speed, position).
    Absolute,
    /// The channel's first sample of the run (seed 004's `dT`).
    First,
    /// A fixed value in the channel's unit (e.g. 20 C, ISO 1).
    Value(f64),
}

/// One model input: a column and its reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Channel {
    /// Run-file column read.
    pub name: Name,
    /// Reference subtracted before the model sees it.
    pub reference: Reference,
}

/// Model kind, as the blob header and `model show` name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum ModelKind {
    /// Transfer-function bank (seed 004).
    Tf = 1,
    /// Linear regression (seed 002).
    Linear = 2,
    /// Principal component regression (seed 003).
    Pcr = 3,
    /// BP network (seeds 000, 003).
    Bp = 4,
    /// ARMA forecaster (seed 001).
    Arma = 5,
    /// Regression over first-order low-pass filter banks (seed 004's
    /// parallel form with fixed real poles).
    Fbank = 6,
}

impl ModelKind {
    /// The kind's code in the blob header.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The kind for a header code.
    pub fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            1 => Self::Tf,
            2 => Self::Linear,
            3 => Self::Pcr,
            4 => Self::Bp,
            5 => Self::Arma,
            6 => Self::Fbank,
            _ => return None,
        })
    }

    /// The name used in specs, the CLI and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::Tf => "tf",
            Self::Linear => "linear",
            Self::Pcr => "pcr",
            Self::Bp => "bp",
            Self::Arma => "arma",
            Self::Fbank => "fbank",
        }
    }

    /// Whether the model has memory (and so a fixed sample time).
    pub fn is_dynamic(self) -> bool {
        matches!(self, Self::Tf | Self::Arma | Self::Fbank)
    }
}

/// The coefficients of one model kind.
// No heap on the hub: one model lives in a static sized by its largest kind,
// so boxing the large variants is not an option.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Params {
    /// Transfer-function bank.
    Tf(heapless::Vec<TfEntry, MAX_TF_ENTRIES>),
    /// Linear regressions.
    Linear(Linear),
    /// Principal component regressions.
    Pcr(Pcr),
    /// BP network.
    Bp(BpNet),
    /// ARMA forecaster.
    Arma(Arma),
    /// Filter-bank regression.
    Fbank(FilterBank),
}

impl Params {
    /// The kind of these coefficients.
    pub fn kind(&self) -> ModelKind {
        match self {
            Self::Tf(_) => ModelKind::Tf,
            Self::Linear(_) => ModelKind::Linear,
            Self::Pcr(_) => ModelKind::Pcr,
            Self::Bp(_) => ModelKind::Bp,
            Self::Arma(_) => ModelKind::Arma,
            Self::Fbank(_) => ModelKind::Fbank,
        }
    }
}

/// Everything a blob carries about a model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Model {
    /// Input channels, indexed by the coefficients.
    pub inputs: heapless::Vec<Channel, MAX_CHANNELS>,
    /// Output names (run-file columns the model predicts).
    pub outputs: heapless::Vec<Name, MAX_OUTPUTS>,
    /// Sample time of a dynamic model, s (0 for static models).
    pub dt_s: f64,
    /// The coefficients.
    pub params: Params,
    /// What calibration saw: the input envelope and the error band
    /// (optional; blob format 2 and later).
    pub bounds: Option<Bounds>,
    /// The tip geometry of a five-point model (outputs `e_um`,
    /// `theta_x_urad`, `theta_y_urad`; [`crate::fivepoint`]); blob format 3
    /// and later.
    pub five_point: Option<FivePoint>,
}

/// A closed range of values, in the quantity's unit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Span {
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

/// Calibration bounds a model may carry: where it was calibrated and how
/// well it predicted there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    /// Per model input (same order as `Model::inputs`): the reference-adjusted range seen in calibration.
    #[serde(deserialize_with = "crate::wire::list")]
    pub envelope: heapless::Vec<Span, MAX_CHANNELS>,
    /// Per model output: half-width of the 95 % band of the calibration cross-validation error, in the output's unit.
    #[serde(deserialize_with = "crate::wire::list")]
    pub half_width: heapless::Vec<f64, MAX_OUTPUTS>,
    /// Per model output: how fast the band widens with extrapolation, per
    /// envelope width (the trainer calibrates it on its cross-validation
    /// folds, each measured against the other folds' envelope).
    #[serde(deserialize_with = "crate::wire::list")]
    pub growth: heapless::Vec<f64, MAX_OUTPUTS>,
}

/// Extrapolation (see [`ValidModel::extrapolation`]) above which the hub
/// raises its "extrapolating" flag: an input more than 10 % of its
/// calibration range outside the envelope. 10 % is where the band
/// [`ValidModel::band_half_width`] has widened by a tenth, a change a user
/// can tell from the calibration figure; below it, sensor noise at the
/// envelope's edge would toggle the flag.
pub const EXTRAPOLATION_FLAG_AT: f64 = 0.1;

/// Relative floor of a span's width in [`ValidModel::extrapolation`]: an input
/// that never moved in calibration (width 0) still gets a finite, very large
/// extrapolation when it moves, scaled by the size of its values.
const SPAN_WIDTH_FLOOR: f64 = 1e-9;

impl Span {
    /// Width `max - min`, floored at `1e-9 max(1, |min|, |max|)`.
    pub fn width(&self) -> f64 {
        let scale = libm::fabs(self.min).max(libm::fabs(self.max)).max(1.0);
        (self.max - self.min).max(SPAN_WIDTH_FLOOR * scale)
    }

    /// How far `x` lies outside the span, in units of its width (0 inside).
    pub fn outside(&self, x: f64) -> f64 {
        let d = if x < self.min {
            self.min - x
        } else if x > self.max {
            x - self.max
        } else {
            0.0
        };
        d / self.width()
    }
}

impl Bounds {
    fn validate(&self, n_in: usize, n_out: usize) -> Result<(), ModelError> {
        if self.envelope.len() != n_in
            || self.half_width.len() != n_out
            || self.growth.len() != n_out
        {
            return Err(ModelError::ShapeMismatch);
        }
        for s in &self.envelope {
            all_bounded(&[s.min, s.max])?;
            if s.min > s.max || !(s.max - s.min).is_finite() {
                return Err(ModelError::BadBounds);
            }
        }
        all_bounded(&self.half_width)?;
        all_bounded(&self.growth)?;
        if self.half_width.iter().chain(&self.growth).any(|h| *h < 0.0) {
            return Err(ModelError::BadBounds);
        }
        Ok(())
    }
}

/// Every value within [`crate::capacity::bounded`] (finite, at most
/// [`crate::capacity::MAX_MAGNITUDE`] in magnitude), else `NonFinite`.
fn all_bounded(values: &[f64]) -> Result<(), ModelError> {
    if values.iter().all(|v| crate::capacity::bounded(*v)) {
        Ok(())
    } else {
        Err(ModelError::NonFinite)
    }
}

fn check_name(name: &str) -> Result<(), ModelError> {
    if name.is_empty() {
        Err(ModelError::EmptyName)
    } else if name.chars().any(char::is_control) {
        Err(ModelError::ControlInName)
    } else {
        Ok(())
    }
}

fn index(i: u8, len: usize) -> Result<usize, ModelError> {
    let i = usize::from(i);
    if i < len {
        Ok(i)
    } else {
        Err(ModelError::IndexOutOfRange)
    }
}

impl Model {
    /// The model's kind.
    pub fn kind(&self) -> ModelKind {
        self.params.kind()
    }

    /// Storage for a model to be decoded into (`blob::decode_into`): no
    /// inputs, no outputs, an empty linear model. Not a valid model.
    pub(crate) fn placeholder() -> Self {
        Self {
            inputs: heapless::Vec::new(),
            outputs: heapless::Vec::new(),
            dt_s: 0.0,
            params: Params::Linear(crate::linear::Linear {
                outputs: heapless::Vec::new(),
            }),
            bounds: None,
            five_point: None,
        }
    }

    /// Checks everything once; the result runs without further checks.
    pub fn validate(self) -> Result<ValidModel, ModelError> {
        let (derived, tip) = self.check()?;
        Ok(ValidModel {
            model: self,
            derived,
            tip,
        })
    }

    /// The checks of [`Model::validate`], on the model where it lies (a
    /// [`crate::slot::ModelSlot`] validates in place); what validation
    /// derives.
    pub(crate) fn check(&self) -> Result<(Derived, Option<TipMap>), ModelError> {
        let (n_in, n_out) = (self.inputs.len(), self.outputs.len());
        if n_in == 0 || n_out == 0 {
            return Err(ModelError::NoInputsOrOutputs);
        }
        for (i, ch) in self.inputs.iter().enumerate() {
            check_name(&ch.name)?;
            if let Reference::Value(v) = ch.reference {
                all_bounded(&[v])?;
            }
            if self.inputs.iter().skip(i + 1).any(|o| o == ch) {
                return Err(ModelError::DuplicateName);
            }
        }
        for (i, name) in self.outputs.iter().enumerate() {
            check_name(name)?;
            if self.outputs.iter().skip(i + 1).any(|o| o == name) {
                return Err(ModelError::DuplicateName);
            }
        }
        if !self.dt_s.is_finite()
            || self.dt_s < 0.0
            || (self.kind().is_dynamic() && self.dt_s <= 0.0)
        {
            return Err(ModelError::BadSampleTime);
        }
        let mut used = [false; MAX_OUTPUTS];
        let mut mark = |o: u8| -> Result<(), ModelError> {
            let o = index(o, n_out)?;
            if let Some(u) = used.get_mut(o) {
                *u = true;
            }
            Ok(())
        };
        if let Some(bounds) = &self.bounds {
            bounds.validate(n_in, n_out)?;
        }
        let mut derived = Derived::None;
        match &self.params {
            Params::Tf(entries) => {
                let mut realised: heapless::Vec<RealisedTf, MAX_TF_ENTRIES> = heapless::Vec::new();
                for (e, entry) in entries.iter().enumerate() {
                    index(entry.input, n_in)?;
                    mark(entry.output)?;
                    let entry_no = u8::try_from(e).unwrap_or(u8::MAX);
                    let tf = RealisedTf::new(&entry.a, &entry.b).map_err(|error| {
                        if error == TfError::NonFinite {
                            ModelError::NonFinite
                        } else {
                            ModelError::Tf {
                                entry: entry_no,
                                error,
                            }
                        }
                    })?;
                    realised.push(tf).map_err(|_| ModelError::ShapeMismatch)?;
                }
                derived = Derived::Tf(realised);
            }
            Params::Linear(lin) => {
                for (k, eq) in lin.outputs.iter().enumerate() {
                    // One regression per output: a second one would be
                    // stored and shown but never computed.
                    if lin.outputs.iter().take(k).any(|o| o.output == eq.output) {
                        return Err(ModelError::DuplicateOutput { output: eq.output });
                    }
                    mark(eq.output)?;
                    all_bounded(&[eq.intercept])?;
                    for c in &eq.coef {
                        index(c.channel, n_in)?;
                        all_bounded(&[c.value])?;
                    }
                    if let Some(pos) = &eq.position {
                        index(pos.channel, n_in)?;
                        if !pos.is_bounded() {
                            return Err(ModelError::NonFinite);
                        }
                    }
                }
            }
            Params::Pcr(pcr) => {
                for ch in &pcr.inputs {
                    index(*ch, n_in)?;
                }
                if pcr.components.is_empty() {
                    return Err(ModelError::ShapeMismatch);
                }
                for comp in &pcr.components {
                    if comp.weights.len() != pcr.inputs.len() {
                        return Err(ModelError::ShapeMismatch);
                    }
                    all_bounded(&comp.weights)?;
                    all_bounded(&[comp.intercept])?;
                }
                for (k, eq) in pcr.outputs.iter().enumerate() {
                    if pcr.outputs.iter().take(k).any(|o| o.output == eq.output) {
                        return Err(ModelError::DuplicateOutput { output: eq.output });
                    }
                    mark(eq.output)?;
                    all_bounded(&[eq.intercept])?;
                    all_bounded(&eq.beta)?;
                    if eq.beta.len() != pcr.components.len() {
                        return Err(ModelError::ShapeMismatch);
                    }
                    if let Some(pos) = &eq.position {
                        index(pos.channel, n_in)?;
                        if !pos.is_bounded() {
                            return Err(ModelError::NonFinite);
                        }
                    }
                }
            }
            Params::Bp(net) => {
                if !net.is_bounded() {
                    return Err(ModelError::NonFinite);
                }
                if !net.shapes_agree() {
                    return Err(ModelError::ShapeMismatch);
                }
                for ch in &net.inputs {
                    index(*ch, n_in)?;
                }
                for (k, o) in net.outputs.iter().enumerate() {
                    if net.outputs.iter().take(k).any(|p| p == o) {
                        return Err(ModelError::DuplicateOutput { output: *o });
                    }
                    mark(*o)?;
                }
            }
            Params::Arma(arma) => {
                let ch = index(arma.channel, n_in)?;
                mark(arma.output)?;
                let absolute = self
                    .inputs
                    .get(ch)
                    .is_some_and(|c| c.reference == Reference::Absolute);
                if !arma.is_bounded() {
                    return Err(ModelError::NonFinite);
                }
                if !arma.is_valid() || !absolute {
                    return Err(ModelError::BadArma);
                }
            }
            Params::Fbank(bank) => {
                derived = Derived::Fbank(bank.validate(n_in, n_out, self.dt_s)?);
                for eq in &bank.outputs {
                    mark(eq.output)?;
                }
            }
        }
        if let Some(o) = used.iter().take(n_out).position(|u| !u) {
            return Err(ModelError::OutputUnused {
                output: u8::try_from(o).unwrap_or(u8::MAX),
            });
        }
        let tip = match &self.five_point {
            Some(fp) => Some(fp.map(&self.outputs)?),
            None => None,
        };
        if tip.is_some() && positional_outputs(&self.params) != 0 {
            return Err(ModelError::BadFivePoint);
        }
        Ok((derived, tip))
    }
}

/// Bit `j` set: output `j` is positional ([`ValidModel::positional_outputs`]).
fn positional_outputs(params: &Params) -> u8 {
    let mut mask = 0u8;
    let mut mark = |output: u8| mask |= 1u8.checked_shl(u32::from(output)).unwrap_or(0);
    match params {
        Params::Linear(lin) => lin
            .outputs
            .iter()
            .filter(|eq| eq.position.is_some())
            .for_each(|eq| mark(eq.output)),
        Params::Pcr(pcr) => pcr
            .outputs
            .iter()
            .filter(|eq| eq.position.is_some())
            .for_each(|eq| mark(eq.output)),
        _ => {}
    }
    mask
}

/// What validation derives from the coefficients of a kind, kept for the
/// run. One slot for all kinds: a model has only one kind, and the hub's
/// model static is sized by its largest variant.
// As for `Params`: no heap on the hub, so no boxing of the large variants.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Derived {
    None,
    /// The realised form of each TF entry.
    Tf(heapless::Vec<RealisedTf, MAX_TF_ENTRIES>),
    /// The pole of each filter-bank feature.
    Fbank([f64; MAX_FB_FEATURES]),
}

/// A model that passed [`Model::validate`]; running it cannot fail.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidModel {
    pub(crate) model: Model,
    pub(crate) derived: Derived,
    pub(crate) tip: Option<TipMap>,
}

/// Why one step produced no outputs (the state is left as it was).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum StepError {
    /// `inputs` does not have one value per model input.
    InputCount {
        /// Values the model needs.
        expected: u8,
        /// Values given.
        got: u8,
    },
    /// `outputs` has room for fewer values than the model produces.
    OutputSpace,
    /// An input is NaN or infinite.
    NonFiniteInput {
        /// Index of the input channel.
        channel: u8,
    },
    /// An input's magnitude exceeds [`MAX_INPUT_MAGNITUDE`]: a broken
    /// reading, refused so that it never enters the model's state.
    InputOutOfRange {
        /// Index of the input channel.
        channel: u8,
    },
    /// The inputs are finite but so extreme that an output overflowed.
    NonFiniteOutput,
}

impl core::fmt::Display for StepError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::InputCount { expected, got } => {
                write!(f, "expected {expected} inputs, got {got}")
            }
            Self::OutputSpace => write!(f, "output buffer too small"),
            Self::NonFiniteInput { channel } => write!(f, "input #{channel} is not finite"),
            Self::InputOutOfRange { channel } => {
                write!(
                    f,
                    "input #{channel} exceeds {MAX_INPUT_MAGNITUDE:e} in magnitude"
                )
            }
            Self::NonFiniteOutput => write!(f, "an output overflowed"),
        }
    }
}

impl core::error::Error for StepError {}

/// The run-time memory of a model: references, TF histories, ARMA history,
/// filter-bank memories.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelState {
    references: [f64; MAX_CHANNELS],
    tf: [TfHistory; MAX_TF_ENTRIES],
    arma: ArmaState,
    fbank: [f64; MAX_FB_FEATURES],
    started: bool,
}

impl Default for ModelState {
    fn default() -> Self {
        Self {
            references: [0.0; MAX_CHANNELS],
            tf: [TfHistory::default(); MAX_TF_ENTRIES],
            arma: ArmaState::default(),
            fbank: [0.0; MAX_FB_FEATURES],
            started: false,
        }
    }
}

impl ModelState {
    /// A state for the start of a run.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forgets everything: the next sample starts a new run.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Whether a first sample has been taken.
    pub fn started(&self) -> bool {
        self.started
    }
}

/// [`ValidModel::settle_s`] through one first-order memory `tau_s`.
fn settle_through(tau_s: f64, lost_s: f64, share: f64) -> f64 {
    if !(tau_s > 0.0 && lost_s > 0.0 && share > 0.0) {
        return 0.0;
    }
    let left = (lost_s / tau_s).min(1.0);
    if left <= share {
        return 0.0;
    }
    tau_s * libm::log(left / share)
}

/// `raw` relative to `reference` (`first`: the run's first sample, taken
/// once the run has `started`; before that the sample is its own
/// reference, 0).
fn adjust(reference: Reference, raw: f64, first: f64, started: bool) -> f64 {
    match reference {
        Reference::Absolute => raw,
        Reference::Value(v) => raw - v,
        Reference::First if !started => 0.0,
        Reference::First => raw - first,
    }
}

fn to_u8(n: usize) -> u8 {
    u8::try_from(n).unwrap_or(u8::MAX)
}

impl ValidModel {
    /// A five-point model's tip geometry (`None` for other models).
    pub fn five_point(&self) -> Option<&TipMap> {
        self.tip.as_ref()
    }

    /// The validated model data.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The model's kind.
    pub fn kind(&self) -> ModelKind {
        self.model.kind()
    }

    /// Input channels.
    pub fn inputs(&self) -> &[Channel] {
        &self.model.inputs
    }

    /// Output names.
    pub fn outputs(&self) -> &[Name] {
        &self.model.outputs
    }

    /// The realised form of each TF entry (empty for other kinds).
    pub fn realised_tfs(&self) -> &[RealisedTf] {
        match &self.derived {
            Derived::Tf(realised) => realised,
            _ => &[],
        }
    }

    /// The pole of each filter-bank feature, in feature order (empty for
    /// other kinds).
    pub fn fbank_poles(&self) -> &[f64] {
        match (&self.derived, &self.model.params) {
            (Derived::Fbank(poles), Params::Fbank(bank)) => {
                poles.get(..bank.features.len()).unwrap_or(&[])
            }
            _ => &[],
        }
    }

    /// How long, s, `output` takes to forget a wrong stretch of `lost_s` in
    /// `input` (a stand-in while it was lost) down to `share` of the
    /// input's full effect. Through a first-order memory of time constant
    /// `tau` the stretch leaves at most `min(lost / tau, 1)` of the effect,
    /// decaying as `exp(-t / tau)`: `tau ln(min(lost / tau, 1) / share)`,
    /// 0 when that is not positive. A filter bank: the longest over the
    /// weighted features of `input` (not the hold of the run's first
    /// sample, which never follows the input). A TF entry, whose poles are
    /// known here by the slowest only: the worst a pole anywhere up to it
    /// can need (the wait peaks at `tau = lost / (share e)`). A static path
    /// (linear, PCR, BP, an unfiltered feature): 0. An ARMA model reads its
    /// own series, not a machine input: 0.
    pub fn settle_s(&self, output: usize, input: usize, lost_s: f64, share: f64) -> f64 {
        let mut wait: f64 = 0.0;
        match &self.model.params {
            Params::Fbank(bank) => {
                let Some(out) = bank
                    .outputs
                    .iter()
                    .find(|o| usize::from(o.output) == output)
                else {
                    return 0.0;
                };
                for (f, w) in bank.features.iter().zip(&out.coef) {
                    if usize::from(f.input) == input && *w != 0.0 && f.tau_s < HOLD_TAU_S {
                        wait = wait.max(settle_through(f.tau_s, lost_s, share));
                    }
                }
            }
            Params::Tf(entries) => {
                let worst_tau = lost_s / (share * core::f64::consts::E);
                for (e, r) in entries.iter().zip(self.realised_tfs()) {
                    if usize::from(e.output) == output && usize::from(e.input) == input {
                        let tau = r.memory_s(self.model.dt_s).min(worst_tau);
                        wait = wait.max(settle_through(tau, lost_s, share));
                    }
                }
            }
            Params::Linear(_) | Params::Pcr(_) | Params::Bp(_) | Params::Arma(_) => {}
        }
        wait
    }

    /// Mends the memories of `input` after it was lost for `lost` steps, in
    /// which the model stepped with `stood_in` standing in for it, now that
    /// it reads `back` (raw values, before this sample's step): they become
    /// what they would be had the input moved along a straight line from
    /// `stood_in` to `back` over the lost steps, which is how a temperature
    /// moves. Each first-order memory of the input gains
    /// `(v(back) - v(stood_in)) line_share` ([`crate::fbank::line_share`],
    /// `v` the feature's power of the reference-adjusted input; a squared
    /// feature follows a line in `v`, not in the input, which the trainer
    /// never asks for: it squares heat sources only, and those are CNC
    /// inputs, which are not bridged). Filter-bank memories only: a TF's
    /// state, a static path, a hold and ARMA's own series have no such
    /// mend. Nothing before the run's first step.
    pub fn bridge(
        &self,
        state: &mut ModelState,
        input: usize,
        (stood_in, back): (f64, f64),
        lost: u32,
    ) {
        let (Params::Fbank(bank), Some(ch), Some(r)) = (
            &self.model.params,
            self.model.inputs.get(input),
            state.references.get(input),
        ) else {
            return;
        };
        if !state.started {
            return;
        }
        let u = |raw: f64| adjust(ch.reference, raw, *r, true);
        let poles = self.fbank_poles();
        for ((f, p), s) in bank.features.iter().zip(poles).zip(state.fbank.iter_mut()) {
            // Unfiltered (p = 0) or a hold (p = 1): no memory to mend.
            if usize::from(f.input) != input || !(*p > 0.0 && *p < 1.0) {
                continue;
            }
            let share = crate::fbank::line_share(f.tau_s, self.model.dt_s, lost);
            let mended = *s + (f.of(u(back)) - f.of(u(stood_in))) * share;
            if mended.is_finite() {
                *s = mended;
            }
        }
    }

    /// The calibration bounds, if the model carries them.
    pub fn bounds(&self) -> Option<&Bounds> {
        self.model.bounds.as_ref()
    }

    /// [`EXTRAPOLATION_FLAG_AT`], on the type that uses it.
    pub const EXTRAPOLATION_FLAG_AT: f64 = EXTRAPOLATION_FLAG_AT;

    /// How far `inputs` (raw values, one per channel) lie outside the
    /// calibration envelope: 0 when the model has no bounds or every
    /// reference-adjusted input lies inside its span; otherwise the largest
    /// distance outside a span divided by that span's width
    /// ([`Span::width`]). The reference adjustment is `step`'s: call it right
    /// after a successful [`ValidModel::step`] with the same `inputs` (a
    /// `First` reference is then the run's first sample). Before the first
    /// step of a run it returns 0: a `First` input has no reference yet.
    /// Inputs `step` would refuse (wrong count: the whole call returns 0;
    /// non-finite or beyond [`MAX_INPUT_MAGNITUDE`]: that input is skipped)
    /// do not count. Never NaN; at most `f64::MAX`.
    pub fn extrapolation(&self, state: &ModelState, inputs: &[f64]) -> f64 {
        let Some(bounds) = &self.model.bounds else {
            return 0.0;
        };
        if !state.started || inputs.len() != self.model.inputs.len() {
            return 0.0;
        }
        let x = self.adjusted(state, inputs);
        let mut worst = 0.0;
        for ((raw, x), span) in inputs.iter().zip(&x).zip(&bounds.envelope) {
            if !raw.is_finite() || libm::fabs(*raw) > MAX_INPUT_MAGNITUDE {
                continue;
            }
            let e = span.outside(*x);
            if e > worst {
                worst = e;
            }
        }
        if worst > f64::MAX {
            f64::MAX
        } else {
            worst
        }
    }

    /// Half-width of the 95 % error band of `output` at `extrapolation`
    /// ([`ValidModel::extrapolation`]): the calibration half-width times
    /// `1 + growth * extrapolation` (a negative or NaN extrapolation counts
    /// as 0).
    /// `None` without bounds or for an output the model does not have.
    pub fn band_half_width(&self, output: usize, extrapolation: f64) -> Option<f64> {
        let bounds = self.model.bounds.as_ref()?;
        let h = *bounds.half_width.get(output)?;
        let g = *bounds.growth.get(output)?;
        let e = if extrapolation > 0.0 {
            extrapolation
        } else {
            0.0
        };
        let w = h * (1.0 + g * e);
        Some(if w > f64::MAX { f64::MAX } else { w })
    }

    /// Takes the model data back.
    pub fn into_model(self) -> Model {
        self.model
    }

    /// The inputs relative to their references: at the first sample of a
    /// run a `Reference::First` input is 0 (the sample is its reference).
    fn adjusted(&self, state: &ModelState, inputs: &[f64]) -> [f64; MAX_CHANNELS] {
        let mut x = [0.0; MAX_CHANNELS];
        for (((xi, raw), ch), r) in x
            .iter_mut()
            .zip(inputs)
            .zip(&self.model.inputs)
            .zip(&state.references)
        {
            *xi = adjust(ch.reference, *raw, *r, state.started);
        }
        x
    }

    /// Bit `j` set: output `j` is a positioning error
    /// ([`PositionTerm`](crate::position::PositionTerm)), sent to a CNC as a
    /// thermal slope ([`ValidModel::thermal_slopes`]).
    pub fn positional_outputs(&self) -> u8 {
        positional_outputs(&self.model.params)
    }

    /// Bit `i` set: output `output` depends on input `i`. A hub whose
    /// input fails holds only the outputs that read it; the others go on.
    /// PCR and BP outputs read every input of the components or the net.
    pub fn output_inputs(&self, output: usize) -> u32 {
        let mut mask = 0u32;
        let mut mark = |ch: u8| mask |= 1u32.checked_shl(u32::from(ch)).unwrap_or(0);
        let is = |o: u8| usize::from(o) == output;
        match &self.model.params {
            Params::Tf(entries) => entries
                .iter()
                .filter(|e| is(e.output))
                .for_each(|e| mark(e.input)),
            Params::Linear(lin) => {
                for eq in lin.outputs.iter().filter(|eq| is(eq.output)) {
                    eq.coef.iter().for_each(|c| mark(c.channel));
                    eq.position.iter().for_each(|p| mark(p.channel));
                }
            }
            Params::Pcr(pcr) => {
                for eq in pcr.outputs.iter().filter(|eq| is(eq.output)) {
                    pcr.inputs.iter().for_each(|&ch| mark(ch));
                    eq.position.iter().for_each(|p| mark(p.channel));
                }
            }
            Params::Bp(net) => {
                if net.outputs.iter().any(|&o| is(o)) {
                    net.inputs.iter().for_each(|&ch| mark(ch));
                }
            }
            Params::Arma(arma) => {
                if is(arma.output) {
                    mark(arma.channel);
                }
            }
            Params::Fbank(bank) => {
                // Every feature a non-zero coefficient of the output reads.
                for eq in bank.outputs.iter().filter(|eq| is(eq.output)) {
                    for (f, c) in bank.features.iter().zip(&eq.coef) {
                        if *c != 0.0 {
                            mark(f.input);
                        }
                    }
                }
            }
        }
        mask
    }

    /// Bit `i` set: input `i` is the axis position of a positional output.
    /// A hub that does not know the position feeds the reference `P0 = 0`
    /// there and sends slopes instead.
    pub fn position_inputs(&self) -> u32 {
        let mut mask = 0u32;
        let mut mark = |ch: u8| mask |= 1u32.checked_shl(u32::from(ch)).unwrap_or(0);
        match &self.model.params {
            Params::Linear(lin) => lin
                .outputs
                .iter()
                .filter_map(|eq| eq.position.as_ref())
                .for_each(|pos| mark(pos.channel)),
            Params::Pcr(pcr) => pcr
                .outputs
                .iter()
                .filter_map(|eq| eq.position.as_ref())
                .for_each(|pos| mark(pos.channel)),
            _ => {}
        }
        mask
    }

    /// The thermal slope `k(T) - k0` (um per mm of travel) of every
    /// positional output ([`ValidModel::positional_outputs`]) at `inputs`,
    /// written to `slopes[j]`; other entries are left alone. Call it right
    /// after a successful [`ValidModel::step`] with the same `inputs` (the
    /// references are then the ones that step used). Positional models are
    /// static, so this changes no state. Refuses, writing nothing, what
    /// `step` would refuse, and a slope that is not finite.
    pub fn thermal_slopes(
        &self,
        state: &ModelState,
        inputs: &[f64],
        slopes: &mut [f64],
    ) -> Result<(), StepError> {
        if inputs.len() != self.model.inputs.len() || !inputs.iter().all(|v| v.is_finite()) {
            return Err(StepError::NonFiniteInput { channel: 0 });
        }
        if slopes.len() < self.model.outputs.len() {
            return Err(StepError::OutputSpace);
        }
        let x = self.adjusted(state, inputs);
        let mut found = [None; MAX_OUTPUTS];
        let mut put = |output: u8, k: f64| {
            if let Some(f) = found.get_mut(usize::from(output)) {
                *f = Some(k);
            }
        };
        match &self.model.params {
            Params::Linear(lin) => lin
                .outputs
                .iter()
                .for_each(|eq| eq.slope(&x).into_iter().for_each(|k| put(eq.output, k))),
            Params::Pcr(pcr) => pcr.slopes(&x, put),
            _ => {}
        }
        if found.iter().flatten().any(|k| !k.is_finite()) {
            return Err(StepError::NonFiniteOutput);
        }
        for (dst, k) in slopes.iter_mut().zip(found) {
            if let Some(k) = k {
                *dst = k;
            }
        }
        Ok(())
    }

    /// One sample: raw input values (one per channel, in channel order) in,
    /// one value per output written to `outputs`. On error nothing is
    /// written and the state is unchanged, so a bad sample can simply be
    /// skipped and the hub holds its last good offsets.
    pub fn step(
        &self,
        state: &mut ModelState,
        inputs: &[f64],
        outputs: &mut [f64],
    ) -> Result<(), StepError> {
        let n_in = self.model.inputs.len();
        let n_out = self.model.outputs.len();
        if inputs.len() != n_in {
            return Err(StepError::InputCount {
                expected: to_u8(n_in),
                got: to_u8(inputs.len()),
            });
        }
        if outputs.len() < n_out {
            return Err(StepError::OutputSpace);
        }
        for (ch, v) in inputs.iter().enumerate() {
            if !v.is_finite() {
                return Err(StepError::NonFiniteInput { channel: to_u8(ch) });
            }
            if libm::fabs(*v) > MAX_INPUT_MAGNITUDE {
                return Err(StepError::InputOutOfRange { channel: to_u8(ch) });
            }
        }
        // Compute everything from the current state without touching it;
        // commit only once every output is known to be finite, so a refused
        // sample leaves the state exactly as it was (and nothing large is
        // copied: only the small per-kind pieces that change).
        let first = !state.started;
        let x = self.adjusted(state, inputs);
        let mut out = [0.0; MAX_OUTPUTS];
        let mut tf_out = [0.0; MAX_TF_ENTRIES];
        let mut arma_next: Option<ArmaState> = None;
        let mut fb_finite = true;
        match &self.model.params {
            Params::Tf(entries) => {
                for (((entry, tf), hist), y) in entries
                    .iter()
                    .zip(self.realised_tfs())
                    .zip(&state.tf)
                    .zip(tf_out.iter_mut())
                {
                    let u = x.get(usize::from(entry.input)).copied().unwrap_or(0.0);
                    *y = if first {
                        tf.output(&tf.steady_state(u), u)
                    } else {
                        tf.output(hist, u)
                    };
                    if let Some(o) = out.get_mut(usize::from(entry.output)) {
                        *o += *y;
                    }
                }
            }
            Params::Linear(lin) => {
                for eq in &lin.outputs {
                    if let Some(o) = out.get_mut(usize::from(eq.output)) {
                        *o = eq.evaluate(&x);
                    }
                }
            }
            Params::Pcr(pcr) => pcr.evaluate(&x, |k, v| {
                if let Some(o) = out.get_mut(usize::from(k)) {
                    *o = v;
                }
            }),
            Params::Bp(net) => net.evaluate(&x, |k, v| {
                if let Some(o) = out.get_mut(usize::from(k)) {
                    *o = v;
                }
            }),
            Params::Arma(arma) => {
                let y = x.get(usize::from(arma.channel)).copied().unwrap_or(0.0);
                let forecast = arma.forecast(&state.arma);
                let mut next = state.arma;
                arma.observe(&mut next, y, forecast);
                if !Arma::state_is_finite(&next) {
                    return Err(StepError::NonFiniteOutput);
                }
                arma_next = Some(next);
                if let Some(o) = out.get_mut(usize::from(arma.output)) {
                    *o = forecast;
                }
            }
            Params::Fbank(bank) => {
                // The new memories are not stored here (that would take
                // MAX_FB_FEATURES f64 of stack); the commit below computes
                // them again, to the same bits.
                for eq in &bank.outputs {
                    if let Some(o) = out.get_mut(usize::from(eq.output)) {
                        *o = eq.intercept;
                    }
                }
                bank.advance(self.fbank_poles(), &state.fbank, &x, first, |j, s| {
                    fb_finite &= s.is_finite();
                    for eq in &bank.outputs {
                        if let (Some(o), Some(c)) =
                            (out.get_mut(usize::from(eq.output)), eq.coef.get(j))
                        {
                            *o += c * s;
                        }
                    }
                });
            }
        }
        let produced = out.get(..n_out).unwrap_or(&[]);
        if !fb_finite || tf_out.iter().chain(produced).any(|v| !v.is_finite()) {
            return Err(StepError::NonFiniteOutput);
        }
        // Commit.
        for (dst, src) in outputs.iter_mut().zip(produced) {
            *dst = *src;
        }
        if let Params::Tf(entries) = &self.model.params {
            for (((entry, tf), hist), y) in entries
                .iter()
                .zip(self.realised_tfs())
                .zip(state.tf.iter_mut())
                .zip(&tf_out)
            {
                let u = x.get(usize::from(entry.input)).copied().unwrap_or(0.0);
                if first {
                    *hist = tf.steady_state(u);
                }
                hist.push(u, *y);
            }
        }
        if let Some(next) = arma_next {
            state.arma = next;
        }
        if let Params::Fbank(bank) = &self.model.params {
            bank.commit(self.fbank_poles(), &mut state.fbank, &x, first);
        }
        if first {
            for (r, raw) in state.references.iter_mut().zip(inputs) {
                *r = *raw;
            }
        }
        state.started = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RAM a hub spends on one loaded model and its state, printed for
    /// docs/benchmarks.md and bounded so that a capacity change is a
    /// decision, not an accident. 32 channels and the 128-feature filter
    /// bank took the pair from 11,640 B to 15,000 B (docs/benchmarks.md);
    /// 256 features (auto's ensembles on 24-32 temperatures, both input
    /// forms on one channel per sensor) to 22,264 B: 7 KiB more of the
    /// STM32F446's 128 KiB. The bound is the measured size and a little, not
    /// a budget.
    #[test]
    fn model_and_state_fit_the_ram_budget() {
        let model = core::mem::size_of::<ValidModel>();
        let state = core::mem::size_of::<ModelState>();
        extern crate std;
        std::eprintln!("ValidModel {model} B, ModelState {state} B");
        std::eprintln!(
            "of which Params {} B (FilterBank {} B, BpNet {} B, TF bank {} B), Option<Bounds> {} B, derived {} B",
            core::mem::size_of::<Params>(),
            core::mem::size_of::<FilterBank>(),
            core::mem::size_of::<BpNet>(),
            core::mem::size_of::<heapless::Vec<TfEntry, MAX_TF_ENTRIES>>(),
            core::mem::size_of::<Option<Bounds>>(),
            core::mem::size_of::<Derived>(),
        );
        assert!(model + state <= 22 * 1024, "{model} + {state} bytes");
    }

    fn arma(phi: &[f64], theta: &[f64]) -> Model {
        Model {
            inputs: heapless::Vec::from_slice(&[Channel {
                name: Name::try_from("dz_um").unwrap(),
                reference: Reference::Absolute,
            }])
            .unwrap(),
            outputs: heapless::Vec::from_slice(&[Name::try_from("dz_um").unwrap()]).unwrap(),
            dt_s: 60.0,
            params: Params::Arma(Arma {
                channel: 0,
                output: 0,
                mean: 0.0,
                std: 1.0,
                diff: 1,
                constant: 0.0,
                phi: heapless::Vec::from_slice(phi).unwrap(),
                theta: heapless::Vec::from_slice(theta).unwrap(),
            }),
            bounds: None,
            five_point: None,
        }
    }

    #[test]
    fn arma_must_be_stationary_and_invertible() {
        // AR roots of z^2 - 0.5 z - 0.3: 0.852 and -0.352, inside: accepted.
        assert!(arma(&[0.5, 0.3], &[-0.4]).validate().is_ok());
        // AR root 1.05 (explosive) and MA root -1.5 (non-invertible): refused.
        assert_eq!(arma(&[1.05], &[]).validate(), Err(ModelError::BadArma));
        assert_eq!(arma(&[0.5], &[1.5]).validate(), Err(ModelError::BadArma));
    }
}
