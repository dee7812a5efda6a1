//! Model specs: a paper's published equations written by hand in TOML
//! (CONTRACT.md section 4), turned into a validated [`model_core::Model`].
//!
//! Errors name the spec file, line and column: TOML syntax and unknown
//! fields from the parser's span, model errors (an unstable TF, a shape that
//! does not agree) from the span of the `[[tf]]`/`[[linear]]`/... entry at
//! fault.

use anyhow::{anyhow, bail, Result};
use model_core::bp::{Activation, BpNet};
use model_core::fbank::{FbOutput, Feature, FilterBank, MAX_FB_FEATURES};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::model::{ModelError, MAX_CHANNELS, MAX_OUTPUTS};
use model_core::pcr::{Component, Pcr, PcrOutput, MAX_COMPONENTS};
use model_core::position::PositionTerm;
use model_core::tf::TfEntry;
use model_core::{Bounds, Channel, Model, Name, Params, Reference, Span, ValidModel};
use serde::Deserialize;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// A reference as written: `"first"`, `"absolute"`, or a number.
#[derive(Deserialize, Debug, Clone, Copy)]
#[serde(
    untagged,
    expecting = "reference must be \"first\", \"absolute\" or a number"
)]
enum RefSpec {
    Word(RefWord),
    Value(f64),
}

#[derive(Deserialize, Debug, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum RefWord {
    First,
    Absolute,
}

impl RefSpec {
    fn reference(self) -> Reference {
        match self {
            Self::Word(RefWord::First) => Reference::First,
            Self::Word(RefWord::Absolute) => Reference::Absolute,
            Self::Value(v) => Reference::Value(v),
        }
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct TfSpec {
    output: String,
    input: String,
    /// Defaults to "first": seed 004 drives each TF by the temperature change.
    reference: Option<RefSpec>,
    a: Vec<f64>,
    b: Vec<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct PositionSpec {
    input: String,
    poly: Vec<f64>,
    k0: f64,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct LinearSpec {
    output: String,
    intercept: f64,
    coef: toml::map::Map<String, toml::Value>,
    /// Defaults to "absolute": seed 002 regresses on the temperatures as read.
    reference: Option<RefSpec>,
    position: Option<PositionSpec>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct ComponentSpec {
    intercept: f64,
    weights: Vec<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct PcrSpec {
    output: String,
    inputs: Vec<String>,
    components: Vec<ComponentSpec>,
    intercept: f64,
    beta: Vec<f64>,
    reference: Option<RefSpec>,
    position: Option<PositionSpec>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct BpSpec {
    inputs: Vec<String>,
    outputs: Vec<String>,
    reference: Option<RefSpec>,
    hidden_activation: Option<String>,
    output_activation: Option<String>,
    /// n rows of m input weights (MATLAB's `net.IW{1,1}`).
    w1: Vec<Vec<f64>>,
    b1: Vec<f64>,
    /// q rows of n hidden weights (MATLAB's `net.LW{2,1}`).
    w2: Vec<Vec<f64>>,
    b2: Vec<f64>,
    x_min: Vec<f64>,
    x_max: Vec<f64>,
    y_min: Vec<f64>,
    y_max: Vec<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct ArmaSpec {
    /// Column whose own past is forecast (e.g. "dz_um").
    series: String,
    /// Output name; defaults to the series, so `eval` scores the forecast.
    output: Option<String>,
    mean: Option<f64>,
    std: Option<f64>,
    diff: Option<u8>,
    constant: Option<f64>,
    #[serde(default)]
    phi: Vec<f64>,
    #[serde(default)]
    theta: Vec<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FbInputSpec {
    name: String,
    /// Defaults to "first": the features are filtered temperature changes.
    reference: Option<RefSpec>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FbFeatureSpec {
    input: String,
    /// Defaults to 1.
    power: Option<u8>,
    /// Defaults to 0 (the unfiltered value).
    tau_s: Option<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FbOutputSpec {
    output: String,
    intercept: f64,
    /// One per feature, in feature order.
    coef: Vec<f64>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct FbankSpec {
    inputs: Vec<FbInputSpec>,
    features: Vec<FbFeatureSpec>,
    output: Vec<FbOutputSpec>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct BoundsSpec {
    /// Per input column: `[min, max]` of the reference-adjusted value.
    envelope: toml::map::Map<String, toml::Value>,
    /// Per output column: the 95 % error half-width.
    half_width: toml::map::Map<String, toml::Value>,
    /// Per output column: widening per envelope width of extrapolation
    /// (default 1).
    #[serde(default)]
    growth: toml::map::Map<String, toml::Value>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    kind: Spanned<String>,
    dt_s: Option<Spanned<f64>>,
    #[serde(default)]
    tf: Vec<Spanned<TfSpec>>,
    #[serde(default)]
    linear: Vec<Spanned<LinearSpec>>,
    #[serde(default)]
    pcr: Vec<Spanned<PcrSpec>>,
    bp: Option<Spanned<BpSpec>>,
    arma: Option<Spanned<ArmaSpec>>,
    fbank: Option<Spanned<FbankSpec>>,
    bounds: Option<Spanned<BoundsSpec>>,
    /// A five-point model's deflection-centre distance, mm (required when
    /// the outputs are `e_um`, `theta_x_urad`, `theta_y_urad`; docs/fivepoint.md).
    l_defl_mm: Option<Spanned<f64>>,
}

/// The five-point geometry of a spec: `l_defl_mm` exactly when the outputs
/// are the five-point ones (model-core checks its range).
fn five_point_of(
    l_defl_mm: Option<&Spanned<f64>>,
    outputs: &[Name],
) -> Result<Option<model_core::fivepoint::FivePoint>> {
    let wanted = model_core::fivepoint::is_five_point(outputs);
    match (l_defl_mm, wanted) {
        (Some(l), true) => Ok(Some(model_core::fivepoint::FivePoint {
            l_defl_mm: *l.get_ref(),
        })),
        (None, false) => Ok(None),
        (None, true) => bail!(
            "the outputs e_um, theta_x_urad, theta_y_urad make a five-point model: give l_defl_mm (mm, top level)"
        ),
        (Some(_), false) => bail!(
            "l_defl_mm is for five-point models only (outputs e_um, theta_x_urad, theta_y_urad)"
        ),
    }
}

fn number(v: &toml::Value, what: &str) -> Result<f64> {
    let x = v
        .as_float()
        .or_else(|| v.as_integer().map(|i| i as f64))
        .ok_or_else(|| anyhow!("{what} is not a number"))?;
    finite(&[x], what)?;
    Ok(x)
}

/// The largest magnitude a spec number may have (but for a feature's
/// hold, below): a coefficient of 1e300 was built, and `predict` then wrote
/// 300-digit offsets. 1e12 leaves room for any physical gain (um per K, um
/// per rpm^2), time constant (s, 30,000 years) or reference. model-core's
/// own bound on every number a model holds (so on a blob from anywhere).
pub const MAX_SPEC_MAGNITUDE: f64 = model_core::capacity::MAX_MAGNITUDE;

/// TOML reads `nan` and `inf` as floats; a coefficient must be finite, and
/// at most [`MAX_SPEC_MAGNITUDE`] in magnitude. Checked here, per entry, so
/// the error names the entry's line and column (model validation would only
/// say that some coefficient is not finite).
fn finite(values: &[f64], what: &str) -> Result<()> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => bail!("{what}: {v} is not a finite number"),
        None => match values.iter().find(|v| v.abs() > MAX_SPEC_MAGNITUDE) {
            Some(v) => bail!("{what}: {v:e} is beyond {MAX_SPEC_MAGNITUDE:e} in magnitude"),
            None => Ok(()),
        },
    }
}

/// A feature's time constant: as [`finite`], except the hold
/// (`model_core::fbank::HOLD_TAU_S`, `f64::MAX`, docs/models.md), which
/// `fit --model auto` and `refit` write for a change from the run's first
/// value.
fn time_constant(tau_s: Option<f64>) -> Result<()> {
    match tau_s {
        Some(t) if t == model_core::fbank::HOLD_TAU_S => Ok(()),
        Some(t) if t > 0.0 => finite(&[t], "tau_s").map_err(|e| {
            anyhow!(
                "{e} (a feature that holds the run's first value has tau_s = \
                 1.7976931348623157e308)"
            )
        }),
        Some(t) => finite(&[t], "tau_s"),
        None => Ok(()),
    }
}

/// As [`finite`], for a reference given as a number.
fn finite_ref(r: Option<RefSpec>) -> Result<()> {
    match r {
        Some(RefSpec::Value(v)) => finite(&[v], "reference"),
        _ => Ok(()),
    }
}

/// As [`finite`], for a position term.
fn finite_position(p: &Option<PositionSpec>) -> Result<()> {
    match p {
        Some(p) => {
            finite(&p.poly, "position.poly")?;
            finite(&[p.k0], "position.k0")
        }
        None => Ok(()),
    }
}

/// The `[bounds]` table for a model with these inputs and outputs: every
/// input column needs a span and every output a half-width.
fn bounds_of(spec: &BoundsSpec, inputs: &[Channel], outputs: &[Name]) -> Result<Bounds> {
    for col in spec.envelope.keys() {
        if !inputs.iter().any(|c| c.name.as_str() == col) {
            bail!("envelope.{col}: not an input of the model");
        }
    }
    for col in spec.half_width.keys().chain(spec.growth.keys()) {
        if !outputs.iter().any(|o| o.as_str() == col) {
            bail!("half_width.{col}: not an output of the model");
        }
    }
    let mut envelope = heapless::Vec::new();
    for ch in inputs {
        let col = ch.name.as_str();
        if inputs.iter().filter(|c| c.name == ch.name).count() > 1 {
            bail!("envelope.{col}: the column is an input twice (two references); bounds are per column");
        }
        let v = spec
            .envelope
            .get(col)
            .ok_or_else(|| anyhow!("envelope has no span for input {col}"))?;
        let pair = v
            .as_array()
            .filter(|a| a.len() == 2)
            .ok_or_else(|| anyhow!("envelope.{col} must be [min, max]"))?;
        let span = Span {
            min: number(&pair[0], &format!("envelope.{col}[0]"))?,
            max: number(&pair[1], &format!("envelope.{col}[1]"))?,
        };
        let _ = envelope.push(span); // capacity MAX_CHANNELS, as `inputs`
    }
    let mut half_width = heapless::Vec::new();
    for o in outputs {
        let col = o.as_str();
        let v = spec
            .half_width
            .get(col)
            .ok_or_else(|| anyhow!("half_width has no value for output {col}"))?;
        let _ = half_width.push(number(v, &format!("half_width.{col}"))?);
    }
    let mut growth = heapless::Vec::new();
    for o in outputs {
        let col = o.as_str();
        let g = match spec.growth.get(col) {
            Some(v) => number(v, &format!("growth.{col}"))?,
            None => 1.0,
        };
        let _ = growth.push(g);
    }
    Ok(Bounds {
        envelope,
        half_width,
        growth,
    })
}

/// Shortest sample time a model or a simulation may have, s: a hub samples
/// its RTDs at most about every 10 ms, and thermal errors move in minutes.
pub const MIN_DT_S: f64 = 1e-3;
/// Longest sample time, s: one day. Beyond it no thermal dynamics are left
/// to model (and `1e300` is a typo).
pub const MAX_DT_S: f64 = 86_400.0;

/// Whether `dt_s` is a usable sample time ([`MIN_DT_S`]..=[`MAX_DT_S`]).
pub fn check_dt_s(dt_s: f64) -> Result<()> {
    if dt_s.is_finite() && (MIN_DT_S..=MAX_DT_S).contains(&dt_s) {
        Ok(())
    } else {
        bail!("{dt_s} s is not a sample time ({MIN_DT_S} s to {MAX_DT_S} s)")
    }
}

/// Line and column (1-based) of a byte offset.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let upto = text.get(..offset.min(text.len())).unwrap_or(text);
    let line = upto.matches('\n').count() + 1;
    let col = upto.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Deserialises TOML text; a syntax or field error is one line naming
/// `file:line:column` (the parser's message may span lines: "invalid
/// array\nexpected `]`", joined with "; ").
pub fn from_toml<T: serde::de::DeserializeOwned>(file: &str, text: &str) -> Result<T> {
    toml::from_str(text).map_err(|e| {
        let (l, c) = e.span().map_or((1, 1), |s| line_col(text, s.start));
        let msg: Vec<&str> = e
            .message()
            .lines()
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .collect();
        anyhow!("{file}:{l}:{c}: {}", msg.join("; "))
    })
}

/// Collects input channels and output names while a spec is translated.
struct Builder<'a> {
    file: &'a str,
    text: &'a str,
    inputs: heapless::Vec<Channel, MAX_CHANNELS>,
    outputs: heapless::Vec<Name, MAX_OUTPUTS>,
}

fn name(s: &str) -> Result<Name> {
    if s.trim().is_empty() {
        bail!("empty column name");
    }
    if s.chars().any(char::is_control) {
        bail!("column name \"{s}\" holds a control character: a model's column names must be printable");
    }
    Name::try_from(s).map_err(|_| {
        anyhow!(
            "column name \"{s}\" is longer than {} bytes",
            model_core::model::NAME_LEN
        )
    })
}

/// `s`'s first `n` characters, control characters escaped (a name holding
/// a line break split the line), then "..." if there is more.
fn shown_first(s: &str, n: usize) -> String {
    let mut out: String = s
        .chars()
        .take(n)
        .map(|c| {
            if c.is_control() {
                c.escape_debug().to_string()
            } else {
                c.to_string()
            }
        })
        .collect();
    if s.chars().nth(n).is_some() {
        out.push_str("...");
    }
    out
}

impl Builder<'_> {
    fn at(&self, span: &Range<usize>) -> String {
        let (l, c) = line_col(self.text, span.start);
        format!("{}:{l}:{c}", self.file)
    }

    fn input(&mut self, column: &str, reference: Reference) -> Result<u8> {
        let ch = Channel {
            name: name(column)?,
            reference,
        };
        let idx = match self.inputs.iter().position(|c| *c == ch) {
            Some(i) => i,
            None => {
                self.inputs
                    .push(ch)
                    .map_err(|_| anyhow!("more than {MAX_CHANNELS} input channels"))?;
                self.inputs.len() - 1
            }
        };
        Ok(u8::try_from(idx)?)
    }

    fn output(&mut self, column: &str) -> Result<u8> {
        let n = name(column)?;
        let idx = match self.outputs.iter().position(|o| *o == n) {
            Some(i) => i,
            None => {
                self.outputs
                    .push(n)
                    .map_err(|_| anyhow!("more than {MAX_OUTPUTS} outputs"))?;
                self.outputs.len() - 1
            }
        };
        Ok(u8::try_from(idx)?)
    }

    fn position(&mut self, p: &Option<PositionSpec>) -> Result<Option<PositionTerm>> {
        let Some(p) = p else { return Ok(None) };
        Ok(Some(PositionTerm {
            channel: self.input(&p.input, Reference::Absolute)?,
            poly: vec_of(&p.poly, "position.poly")?,
            k0: p.k0,
        }))
    }
}

fn vec_of<T: Clone, const N: usize>(values: &[T], what: &str) -> Result<heapless::Vec<T, N>> {
    heapless::Vec::from_slice(values)
        .map_err(|_| anyhow!("{what} has {} values, at most {N} allowed", values.len()))
}

fn activation(s: Option<&str>, default: Activation) -> Result<Activation> {
    Ok(match s {
        None => default,
        Some("tansig") => Activation::Tansig,
        Some("logsig") => Activation::Logsig,
        Some("purelin") => Activation::Purelin,
        Some(other) => bail!("unknown activation \"{other}\" (tansig, logsig or purelin)"),
    })
}

/// Refuses a second `[[kind]]` entry for an output already computed by an
/// earlier one (`seen`: output and where its entry starts). A regression
/// output is one equation; unlike the terms of a transfer-function bank,
/// two equations for one output do not add up, and only the last would run.
fn once_per_output<'s>(
    seen: &mut Vec<(&'s str, String)>,
    output: &'s str,
    at: &str,
    kind: &str,
) -> Result<()> {
    if let Some((_, first)) = seen.iter().find(|(o, _)| *o == output) {
        bail!(
            "{at}: [[{kind}]] {output}: the output already has an entry (at {first}); one [[{kind}]] per output"
        );
    }
    seen.push((output, at.to_string()));
    Ok(())
}

/// The `tf` kind's parameters from its spec entries (their spans go to
/// `spans`, so a model error can point at its entry).
fn tf_params(
    spec: &SpecFile,
    b: &mut Builder,
    kind_at: &str,
    spans: &mut Vec<Range<usize>>,
) -> Result<Params> {
    if spec.tf.is_empty() {
        bail!("{kind_at}: kind = \"tf\" needs at least one [[tf]] entry");
    }
    let mut entries = heapless::Vec::new();
    for e in &spec.tf {
        let span = e.span();
        let at = b.at(&span);
        let t = e.get_ref();
        let entry = (|| -> Result<TfEntry> {
            finite_ref(t.reference)?;
            finite(&t.a, "a")?;
            finite(&t.b, "b")?;
            let reference = t.reference.map_or(Reference::First, RefSpec::reference);
            Ok(TfEntry {
                output: b.output(&t.output)?,
                input: b.input(&t.input, reference)?,
                a: vec_of(&t.a, "a")?,
                b: vec_of(&t.b, "b")?,
            })
        })()
        .map_err(|err| anyhow!("{at}: [[tf]] {} <- {}: {err}", t.output, t.input))?;
        entries
            .push(entry)
            .map_err(|_| anyhow!("{at}: more than {} [[tf]] entries", entries.capacity()))?;
        spans.push(span);
    }
    Ok(Params::Tf(entries))
}

/// The `linear` kind's parameters from its spec entries (their spans go to
/// `spans`, so a model error can point at its entry).
fn linear_params(
    spec: &SpecFile,
    b: &mut Builder,
    kind_at: &str,
    spans: &mut Vec<Range<usize>>,
) -> Result<Params> {
    if spec.linear.is_empty() {
        bail!("{kind_at}: kind = \"linear\" needs at least one [[linear]] entry");
    }
    let mut outputs = heapless::Vec::new();
    let mut seen: Vec<(&str, String)> = Vec::new();
    for e in &spec.linear {
        let span = e.span();
        let at = b.at(&span);
        let l = e.get_ref();
        once_per_output(&mut seen, &l.output, &at, "linear")?;
        let eq = (|| -> Result<LinearOutput> {
            finite_ref(l.reference)?;
            finite(&[l.intercept], "intercept")?;
            finite_position(&l.position)?;
            let reference = l.reference.map_or(Reference::Absolute, RefSpec::reference);
            let mut coef = heapless::Vec::new();
            for (col, v) in &l.coef {
                let value = number(v, &format!("coef.{col}"))?;
                coef.push(Coef {
                    channel: b.input(col, reference)?,
                    value,
                })
                .map_err(|_| anyhow!("more than {MAX_CHANNELS} coefficients"))?;
            }
            Ok(LinearOutput {
                output: b.output(&l.output)?,
                intercept: l.intercept,
                coef,
                position: b.position(&l.position)?,
            })
        })()
        .map_err(|err| anyhow!("{at}: [[linear]] {}: {err}", l.output))?;
        outputs
            .push(eq)
            .map_err(|_| anyhow!("{at}: more than {MAX_OUTPUTS} [[linear]] entries"))?;
        spans.push(span);
    }
    Ok(Params::Linear(Linear { outputs }))
}

/// One `[[pcr]]` entry: its inputs (channels), where its components start
/// among all entries' components, and its equation on its own components.
struct PcrEntry {
    inputs: Vec<u8>,
    first_component: usize,
    eq: PcrOutput,
}

/// A `[[pcr]]` entry's numbers are finite and no input is listed twice
/// (each input has one weight per component; a repeat would silently keep
/// only the last one).
fn check_pcr_values(p: &PcrSpec) -> Result<()> {
    finite_ref(p.reference)?;
    finite(&[p.intercept], "intercept")?;
    finite(&p.beta, "beta")?;
    finite_position(&p.position)?;
    for (j, c) in p.components.iter().enumerate() {
        finite(&[c.intercept], &format!("component {} intercept", j + 1))?;
        finite(&c.weights, &format!("component {} weights", j + 1))?;
    }
    for (i, col) in p.inputs.iter().enumerate() {
        if p.inputs[..i].contains(col) {
            bail!("input {col} is listed twice");
        }
    }
    Ok(())
}

/// Each component of a `[[pcr]]` entry has a weight per input, and the
/// output a beta per component.
fn check_pcr_shapes(p: &PcrSpec) -> Result<()> {
    for (j, c) in p.components.iter().enumerate() {
        if c.weights.len() != p.inputs.len() {
            bail!(
                "component {} has {} weights for {} inputs",
                j + 1,
                c.weights.len(),
                p.inputs.len()
            );
        }
    }
    if p.beta.len() != p.components.len() {
        bail!(
            "{} beta values for {} components",
            p.beta.len(),
            p.components.len()
        );
    }
    Ok(())
}

/// The merged components: each entry's, with weight 0 on the inputs of
/// `union` it lacks. `raw` holds `(entry, intercept, weights)`.
fn merged_components(
    raw: &[(usize, f64, Vec<f64>)],
    entries: &[PcrEntry],
    union: &[u8],
) -> Result<heapless::Vec<Component, MAX_COMPONENTS>> {
    let mut components = heapless::Vec::new();
    for (owner, intercept, weights) in raw {
        let mut w = vec![0.0; union.len()];
        for (ch, v) in entries[*owner].inputs.iter().zip(weights) {
            if let Some(pos) = union.iter().position(|u| u == ch) {
                w[pos] = *v;
            }
        }
        let _ = components.push(Component {
            intercept: *intercept,
            weights: vec_of(&w, "weights")?,
        });
    }
    Ok(components)
}

/// Each entry's equation on all `n_components` merged components (beta 0
/// on the other entries').
fn merged_outputs(
    entries: Vec<PcrEntry>,
    n_components: usize,
    file: &str,
) -> Result<heapless::Vec<PcrOutput, MAX_OUTPUTS>> {
    let mut outputs = heapless::Vec::new();
    for entry in entries {
        let mut beta = vec![0.0; n_components];
        for (j, v) in entry.eq.beta.iter().enumerate() {
            beta[entry.first_component + j] = *v;
        }
        outputs
            .push(PcrOutput {
                beta: vec_of(&beta, "beta")?,
                ..entry.eq
            })
            .map_err(|_| anyhow!("{file}: more than {MAX_OUTPUTS} [[pcr]] entries"))?;
    }
    Ok(outputs)
}

/// The `pcr` kind's parameters from its spec entries (their spans go to
/// `spans`, so a model error can point at its entry).
fn pcr_params(
    spec: &SpecFile,
    b: &mut Builder,
    kind_at: &str,
    spans: &mut Vec<Range<usize>>,
) -> Result<Params> {
    let file = b.file;
    if spec.pcr.is_empty() {
        bail!("{kind_at}: kind = \"pcr\" needs at least one [[pcr]] entry");
    }
    // Each entry brings its own inputs and components; the model
    // shares one set, so entries are merged exactly: the union of
    // inputs (weight 0 where an entry lacks one) and all components
    // (each output's beta 0 on the others' components).
    let mut entries: Vec<PcrEntry> = Vec::new();
    let mut union: Vec<u8> = Vec::new();
    let mut raw_components: Vec<(usize, f64, Vec<f64>)> = Vec::new();
    let mut seen: Vec<(&str, String)> = Vec::new();
    for e in &spec.pcr {
        let span = e.span();
        let at = b.at(&span);
        let p = e.get_ref();
        once_per_output(&mut seen, &p.output, &at, "pcr")?;
        let entry = (|| -> Result<PcrEntry> {
            let reference = p.reference.map_or(Reference::Absolute, RefSpec::reference);
            check_pcr_values(p)?;
            let inputs = p
                .inputs
                .iter()
                .map(|col| b.input(col, reference))
                .collect::<Result<Vec<u8>>>()?;
            for ch in &inputs {
                if !union.contains(ch) {
                    union.push(*ch);
                }
            }
            check_pcr_shapes(p)?;
            let first_component = raw_components.len();
            for c in &p.components {
                raw_components.push((entries.len(), c.intercept, c.weights.clone()));
            }
            Ok(PcrEntry {
                inputs,
                first_component,
                eq: PcrOutput {
                    output: b.output(&p.output)?,
                    intercept: p.intercept,
                    beta: vec_of(&p.beta, "beta")?,
                    position: b.position(&p.position)?,
                },
            })
        })()
        .map_err(|err| anyhow!("{at}: [[pcr]] {}: {err}", p.output))?;
        entries.push(entry);
        spans.push(span);
    }
    if raw_components.len() > MAX_COMPONENTS {
        bail!(
            "{file}: {} components in all, a model holds at most {MAX_COMPONENTS}",
            raw_components.len()
        );
    }
    let components = merged_components(&raw_components, &entries, &union)?;
    let outputs = merged_outputs(entries, raw_components.len(), file)?;
    Ok(Params::Pcr(Pcr {
        inputs: vec_of(&union, "inputs")?,
        components,
        outputs,
    }))
}

/// A kind's parameters from its one `[table]` (`what`: "a [bp]"): a clear
/// error if the table is missing, `build` over it with its errors prefixed
/// by the table's position, and its span recorded in `spans` (so a model
/// error can point at it).
fn from_table<T, P>(
    entry: Option<&Spanned<T>>,
    what: &str,
    b: &mut Builder,
    kind_at: &str,
    spans: &mut Vec<Range<usize>>,
    build: impl FnOnce(&T, &mut Builder) -> Result<P>,
) -> Result<P> {
    let kind = what
        .trim_start_matches(|c: char| c != '[')
        .trim_matches(|c| c == '[' || c == ']');
    let e = entry.ok_or_else(|| anyhow!("{kind_at}: kind = \"{kind}\" needs {what} table"))?;
    let span = e.span();
    let at = b.at(&span);
    let params = build(e.get_ref(), b).map_err(|err| anyhow!("{at}: [{kind}]: {err}"))?;
    spans.push(span);
    Ok(params)
}

/// The `bp` kind's parameters from its spec entries (their spans go to
/// `spans`, so a model error can point at its entry).
fn bp_params(
    spec: &SpecFile,
    b: &mut Builder,
    kind_at: &str,
    spans: &mut Vec<Range<usize>>,
) -> Result<Params> {
    let net = from_table(
        spec.bp.as_ref(),
        "a [bp]",
        b,
        kind_at,
        spans,
        |n, b| -> Result<BpNet> {
            finite_ref(n.reference)?;
            for (what, rows) in [("w1", &n.w1), ("w2", &n.w2)] {
                for row in rows.iter() {
                    finite(row, what)?;
                }
            }
            for (what, v) in [
                ("b1", &n.b1),
                ("b2", &n.b2),
                ("x_min", &n.x_min),
                ("x_max", &n.x_max),
                ("y_min", &n.y_min),
                ("y_max", &n.y_max),
            ] {
                finite(v, what)?;
            }
            let reference = n.reference.map_or(Reference::Absolute, RefSpec::reference);
            let (m, hidden, q) = (n.inputs.len(), n.b1.len(), n.outputs.len());
            if n.w1.len() != hidden || n.w1.iter().any(|r| r.len() != m) {
                bail!("w1 must be {hidden} rows (one per b1 value) of {m} weights (one per input)");
            }
            if n.w2.len() != q || n.w2.iter().any(|r| r.len() != hidden) {
                bail!("w2 must be {q} rows (one per output) of {hidden} weights");
            }
            let mut inputs = heapless::Vec::new();
            for col in &n.inputs {
                inputs
                    .push(b.input(col, reference)?)
                    .map_err(|_| anyhow!("more than {MAX_CHANNELS} inputs"))?;
            }
            let mut outputs = heapless::Vec::new();
            for (i, col) in n.outputs.iter().enumerate() {
                if n.outputs[..i].contains(col) {
                    bail!("output {col} is listed twice");
                }
                outputs
                    .push(b.output(col)?)
                    .map_err(|_| anyhow!("more than {MAX_OUTPUTS} outputs"))?;
            }
            let w1: Vec<f64> = n.w1.iter().flatten().copied().collect();
            let w2: Vec<f64> = n.w2.iter().flatten().copied().collect();
            Ok(BpNet {
                inputs,
                outputs,
                hidden_activation: activation(n.hidden_activation.as_deref(), Activation::Tansig)?,
                output_activation: activation(n.output_activation.as_deref(), Activation::Purelin)?,
                w1: vec_of(&w1, "w1")?,
                b1: vec_of(&n.b1, "b1")?,
                w2: vec_of(&w2, "w2")?,
                b2: vec_of(&n.b2, "b2")?,
                x_min: vec_of(&n.x_min, "x_min")?,
                x_max: vec_of(&n.x_max, "x_max")?,
                y_min: vec_of(&n.y_min, "y_min")?,
                y_max: vec_of(&n.y_max, "y_max")?,
            })
        },
    )?;
    Ok(Params::Bp(net))
}

/// The `arma` kind's parameters from its spec entries (their spans go to
/// `spans`, so a model error can point at its entry).
fn arma_params(
    spec: &SpecFile,
    b: &mut Builder,
    kind_at: &str,
    spans: &mut Vec<Range<usize>>,
) -> Result<Params> {
    let arma = from_table(
        spec.arma.as_ref(),
        "an [arma]",
        b,
        kind_at,
        spans,
        |a, b| -> Result<model_core::arma::Arma> {
            let scalars = [a.mean, a.std, a.constant];
            finite(
                &scalars.iter().flatten().copied().collect::<Vec<_>>(),
                "mean/std/constant",
            )?;
            finite(&a.phi, "phi")?;
            finite(&a.theta, "theta")?;
            Ok(model_core::arma::Arma {
                channel: b.input(&a.series, Reference::Absolute)?,
                output: b.output(a.output.as_deref().unwrap_or(&a.series))?,
                mean: a.mean.unwrap_or(0.0),
                std: a.std.unwrap_or(1.0),
                diff: a.diff.unwrap_or(0),
                constant: a.constant.unwrap_or(0.0),
                phi: vec_of(&a.phi, "phi")?,
                theta: vec_of(&a.theta, "theta")?,
            })
        },
    )?;
    Ok(Params::Arma(arma))
}

/// The `fbank` kind's parameters from its spec entries (their spans go to
/// `spans`, so a model error can point at its entry).
fn fbank_params(
    spec: &SpecFile,
    b: &mut Builder,
    kind_at: &str,
    spans: &mut Vec<Range<usize>>,
) -> Result<Params> {
    let bank = from_table(
        spec.fbank.as_ref(),
        "an [fbank]",
        b,
        kind_at,
        spans,
        |f, b| -> Result<FilterBank> {
            for i in &f.inputs {
                finite_ref(i.reference)?;
            }
            for ft in &f.features {
                time_constant(ft.tau_s)?;
            }
            for o in &f.output {
                finite(&[o.intercept], "intercept")?;
                finite(&o.coef, "coef")?;
            }
            let mut by_name: Vec<(&str, u8)> = Vec::new();
            for i in &f.inputs {
                if by_name.iter().any(|(n, _)| *n == i.name) {
                    bail!("input {} is listed twice", i.name);
                }
                let reference = i.reference.map_or(Reference::First, RefSpec::reference);
                by_name.push((&i.name, b.input(&i.name, reference)?));
            }
            let mut features = heapless::Vec::new();
            for (j, ft) in f.features.iter().enumerate() {
                let input = by_name
                    .iter()
                    .find(|(n, _)| *n == ft.input)
                    .map(|(_, i)| *i)
                    .ok_or_else(|| {
                        anyhow!("feature {}: input {} is not in inputs", j + 1, ft.input)
                    })?;
                features
                    .push(Feature {
                        input,
                        power: ft.power.unwrap_or(1),
                        tau_s: ft.tau_s.unwrap_or(0.0),
                    })
                    .map_err(|_| anyhow!("more than {MAX_FB_FEATURES} features"))?;
            }
            let mut outputs = heapless::Vec::new();
            for o in &f.output {
                if o.coef.len() != features.len() {
                    bail!(
                        "output {}: {} coef values for {} features",
                        o.output,
                        o.coef.len(),
                        features.len()
                    );
                }
                outputs
                    .push(FbOutput {
                        output: b.output(&o.output)?,
                        intercept: o.intercept,
                        coef: vec_of(&o.coef, "coef")?,
                    })
                    .map_err(|_| anyhow!("more than {MAX_OUTPUTS} outputs"))?;
            }
            Ok(FilterBank { features, outputs })
        },
    )?;
    Ok(Params::Fbank(bank))
}

/// Reads and validates a spec file.
pub fn load(path: &Path) -> Result<ValidModel> {
    let text = crate::data::fsio::read_text_capped(path)?;
    parse(&path.display().to_string(), &text)
}

/// Parses and validates spec text; `file` names it in errors, which are
/// one bounded line whatever the spec holds (see [`bounded`]).
pub fn parse(file: &str, text: &str) -> Result<ValidModel> {
    parse_unbounded(file, text).map_err(|e| {
        let msg = format!("{e:#}");
        match msg.strip_prefix(file) {
            Some(rest) => anyhow!("{file}{}", bounded(rest)),
            None => anyhow!("{}", bounded(&msg)),
        }
    })
}

/// An error message (after its `file` prefix, kept whole) as one line of
/// bounded length: control characters escaped (a name holding a line break
/// split the line), every word longer than 200 characters cut to its first
/// 40, and the whole cut at 1,000 characters (a 900,000-character name made
/// a 1.8 MB message).
fn bounded(msg: &str) -> String {
    const LONG: usize = 200;
    let words = msg
        .split(' ')
        .map(|word| {
            if word.chars().nth(LONG).is_some() {
                shown_first(word, 40)
            } else {
                shown_first(word, LONG)
            }
        })
        .collect::<Vec<_>>()
        .join(" ");
    shown_first(&words, 1000)
}

fn parse_unbounded(file: &str, text: &str) -> Result<ValidModel> {
    let spec: SpecFile = from_toml(file, text)?;
    let mut b = Builder {
        file,
        text,
        inputs: heapless::Vec::new(),
        outputs: heapless::Vec::new(),
    };
    // Spans of the entries, so a model error can point at its entry.
    let mut spans: Vec<Range<usize>> = Vec::new();
    // Errors about the kind as a whole point at its `kind = ...` line.
    let kind_at = b.at(&spec.kind.span());
    let kind = spec.kind.get_ref().as_str();
    let expect_only = |present: &[(&str, bool)], kind: &str| -> Result<()> {
        for (section, has) in present {
            if *has && *section != kind {
                bail!("{kind_at}: kind = \"{kind}\" but the spec has [{section}] entries");
            }
        }
        Ok(())
    };
    expect_only(
        &[
            ("tf", !spec.tf.is_empty()),
            ("linear", !spec.linear.is_empty()),
            ("pcr", !spec.pcr.is_empty()),
            ("bp", spec.bp.is_some()),
            ("arma", spec.arma.is_some()),
            ("fbank", spec.fbank.is_some()),
        ],
        kind,
    )?;
    let params = match kind {
        "tf" => tf_params(&spec, &mut b, &kind_at, &mut spans)?,
        "linear" => linear_params(&spec, &mut b, &kind_at, &mut spans)?,
        "pcr" => pcr_params(&spec, &mut b, &kind_at, &mut spans)?,
        "bp" => bp_params(&spec, &mut b, &kind_at, &mut spans)?,
        "arma" => arma_params(&spec, &mut b, &kind_at, &mut spans)?,
        "fbank" => fbank_params(&spec, &mut b, &kind_at, &mut spans)?,
        other => bail!("{kind_at}: unknown kind \"{other}\" (tf, linear, pcr, bp, arma or fbank)"),
    };
    let dynamic = params.kind().is_dynamic();
    let dt_s = match (dynamic, &spec.dt_s) {
        (true, Some(dt)) => {
            check_dt_s(*dt.get_ref()).map_err(|e| anyhow!("{}: dt_s: {e}", b.at(&dt.span())))?;
            *dt.get_ref()
        }
        (true, None) => bail!("{kind_at}: kind = \"{kind}\" is dynamic and needs dt_s"),
        (false, dt) => dt.as_ref().map_or(0.0, |d| *d.get_ref()),
    };
    let bounds = match &spec.bounds {
        Some(e) => Some(
            bounds_of(e.get_ref(), &b.inputs, &b.outputs)
                .map_err(|err| anyhow!("{}: [bounds]: {err}", b.at(&e.span())))?,
        ),
        None => None,
    };
    let five_point = five_point_of(spec.l_defl_mm.as_ref(), &b.outputs)
        .map_err(|e| anyhow!("{}: {e}", kind_at))?;
    let model = Model {
        inputs: b.inputs,
        outputs: b.outputs,
        dt_s,
        params,
        bounds,
        five_point,
    };
    model.validate().map_err(|e| match e {
        ModelError::Tf { entry, error } => {
            let span = spans.get(usize::from(entry)).cloned().unwrap_or(0..0);
            let (l, c) = line_col(text, span.start);
            anyhow!(
                "{file}:{l}:{c}: [[tf]] entry {}: {error}",
                usize::from(entry) + 1
            )
        }
        other => anyhow!("{file}: {other}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SP2_AMB: &str = r#"
kind = "tf"
dt_s = 1.0

[[tf]]
output = "dz_um"
input = "T1"
reference = "first"
a = [16.0005, -15.9975, 0.0]
b = [1.0, -0.99983]

[[tf]]
output = "dz_um"
input = "ambient_c"
reference = "first"
a = [-0.0251, 0.0251, 0.0]
b = [1.0, -1.9985, 0.9985]
"#;

    #[test]
    fn seed004_sp2_and_ambient() {
        let m = parse("sp2.toml", SP2_AMB).unwrap();
        assert_eq!(m.inputs().len(), 2);
        assert_eq!(m.outputs().len(), 1);
        assert_eq!(m.realised_tfs()[1].cancelled(), 1);
    }

    #[test]
    fn syntax_and_field_errors_name_line_and_column() {
        let bad = SP2_AMB.replace(
            "reference = \"first\"\na = [16",
            "refrence = \"first\"\na = [16",
        );
        let e = parse("sp2.toml", &bad).unwrap_err().to_string();
        assert!(
            e.starts_with("sp2.toml:8:1: unknown field `refrence`"),
            "{e}"
        );
        let e = parse("x.toml", "kind = \"tf\"\ndt_s = [")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("x.toml:2:"), "{e}");
        assert!(!e.contains('\n'), "one line: {e}");
    }

    #[test]
    fn unstable_tf_points_at_its_entry() {
        let bad = SP2_AMB.replace("b = [1.0, -0.99983]", "b = [1.0, -1.2]");
        let e = parse("sp2.toml", &bad).unwrap_err().to_string();
        assert!(
            e.starts_with("sp2.toml:5:1: [[tf]] entry 1: unstable"),
            "{e}"
        );
    }

    /// Issue 14: a repeated pcr input kept only its last weight, and a
    /// second `[[linear]]`/`[[pcr]]` for one output was stored and shown but
    /// never computed. Both are refused at the entry's line and column.
    #[test]
    fn repeated_inputs_and_outputs_are_refused_at_their_entry() {
        let pcr = "kind = \"pcr\"\n[[pcr]]\noutput = \"k\"\ninputs = [\"T1\", \"T2\", \"T1\"]\n\
                   components = [{ intercept = 0.0, weights = [1.0, 2.0, 3.0] }]\nintercept = 0.0\nbeta = [1.0]\n";
        let e = parse("p.toml", pcr).unwrap_err().to_string();
        assert!(
            e.starts_with("p.toml:2:1: [[pcr]] k: input T1 is listed twice"),
            "{e}"
        );

        let one = "[[linear]]\noutput = \"x_um\"\nintercept = 0.0\ncoef = { T1 = 1.0 }\n";
        let two = format!("kind = \"linear\"\n{one}{}", one.replace("T1", "T2"));
        let e = parse("l.toml", &two).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "l.toml:6:1: [[linear]] x_um: the output already has an entry (at l.toml:2:1)"
            ),
            "{e}"
        );
        // Different outputs are fine.
        parse("l.toml", &two.replacen("x_um", "y_um", 1)).unwrap();

        let one = "[[pcr]]\noutput = \"k\"\ninputs = [\"T1\"]\ncomponents = [{ intercept = 0.0, weights = [1.0] }]\nintercept = 0.0\nbeta = [1.0]\n";
        let two = format!("kind = \"pcr\"\n{one}{one}");
        let e = parse("p.toml", &two).unwrap_err().to_string();
        assert!(
            e.starts_with("p.toml:8:1: [[pcr]] k: the output already has an entry"),
            "{e}"
        );
    }

    #[test]
    fn seed002_linear_and_seed003_pcr() {
        let lin = r#"
kind = "linear"
[[linear]]
output = "x_um"
intercept = -0.2565
coef = { T3 = 0.0189, T4 = -0.0124, T10 = 0.0082, T12 = -0.0074 }
"#;
        let m = parse("l.toml", lin).unwrap();
        let names: Vec<&str> = m.inputs().iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["T3", "T4", "T10", "T12"], "key order preserved");
        let pcr = r#"
kind = "pcr"
[[pcr]]
output = "k"
inputs = ["T1", "T2", "T5", "T7", "T11"]
components = [{ intercept = -50.6062, weights = [0.1631, 0.4902, 0.2512, 0.6614, 1.1666] }]
intercept = -0.3243
beta = [0.0396]
"#;
        parse("p.toml", pcr).unwrap();
        let e = parse(
            "p.toml",
            &pcr.replace("beta = [0.0396]", "beta = [0.0396, 1.0]"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("2 beta values for 1 components"), "{e}");
    }
}

#[cfg(test)]
mod fbank_tests {
    use super::*;

    const FB: &str = r#"
kind = "fbank"
dt_s = 30.0

[fbank]
inputs = [{ name = "T1" }, { name = "T2", reference = "absolute" }]
features = [{ input = "T1" }, { input = "T1", tau_s = 600.0 }, { input = "T2", power = 2 }]

[[fbank.output]]
output = "dz_um"
intercept = 0.5
coef = [1.0, 2.0, 0.01]

[bounds]
envelope = { T1 = [0.0, 10.0], T2 = [15.0, 30.0] }
half_width = { dz_um = 1.2 }
"#;

    #[test]
    fn fbank_with_bounds() {
        let m = parse("fb.toml", FB).unwrap();
        assert_eq!(m.kind(), model_core::ModelKind::Fbank);
        assert_eq!(m.inputs()[1].reference, Reference::Absolute);
        // exp(-30 / 600) = 0.951229424500714 (Python math.exp).
        assert!((m.fbank_poles()[1] - 0.951_229_424_500_714).abs() < 1e-15);
        let b = m.bounds().unwrap();
        assert_eq!(
            b.envelope[1],
            Span {
                min: 15.0,
                max: 30.0
            }
        );
        assert_eq!(b.half_width[0], 1.2);
    }

    #[test]
    fn fbank_mistakes_are_named() {
        let cases = [
            (
                "coef = [1.0, 2.0, 0.01]",
                "coef = [1.0, 2.0]",
                "2 coef values for 3 features",
            ),
            (
                "{ input = \"T2\", power = 2 }",
                "{ input = \"T3\" }",
                "input T3 is not in inputs",
            ),
            (
                "{ input = \"T2\", power = 2 }",
                "{ input = \"T2\", power = 3 }",
                "power must be 1 or 2",
            ),
            ("tau_s = 600.0", "tau_s = -1.0", "tau_s >= 0"),
            // Beyond 1e12 s is refused, naming the hold's spelling; the hold
            // itself builds (below).
            (
                "tau_s = 600.0",
                "tau_s = 1e13",
                "tau_s: 1e13 is beyond 1e12 in magnitude (a feature that holds",
            ),
            (
                ", T2 = [15.0, 30.0]",
                "",
                "envelope has no span for input T2",
            ),
            ("T2 = [15.0, 30.0]", "T2 = [30.0, 15.0]", "min > max"),
            (
                "dz_um = 1.2",
                "dx_um = 1.2",
                "half_width.dx_um: not an output",
            ),
            ("dt_s = 30.0", "", "is dynamic and needs dt_s"),
        ];
        for (from, to, expected) in cases {
            let text = FB.replace(from, to);
            assert_ne!(text, FB, "{from}");
            let e = parse("fb.toml", &text).unwrap_err().to_string();
            assert!(e.contains(expected), "{expected:?} not in {e}");
        }
        // Whatever a name holds, the error is one line of bounded length:
        // a line break in a feature's input, a 900,000-byte envelope key.
        let long = "x".repeat(900_000);
        for text in [
            FB.replace("{ input = \"T2\", power = 2 }", "{ input = \"a\\nb\" }"),
            FB.replace("T2 = [15.0, 30.0]", &format!("{long} = [15.0, 30.0]")),
        ] {
            let e = parse("fb.toml", &text).unwrap_err().to_string();
            assert!(
                !e.contains('\n') && e.len() < 300,
                "{}",
                &e[..e.len().min(300)]
            );
        }
        let e = parse(
            "fb.toml",
            &FB.replace("{ input = \"T2\", power = 2 }", "{ input = \"a\\nb\" }"),
        );
        assert!(e
            .unwrap_err()
            .to_string()
            .contains("input a\\nb is not in inputs"));
        // A long name with spaces: the whole line is cut (1,000 characters);
        // a long file path stays whole, its line:column with it.
        let spaced = format!("\"{}\" = [15.0, 30.0]", "a ".repeat(450_000));
        let e = parse("fb.toml", &FB.replace("T2 = [15.0, 30.0]", &spaced));
        assert!(e.unwrap_err().to_string().len() < 1100);
        let deep = format!("{}fb.toml", "d/".repeat(300));
        let e = parse(&deep, &FB.replace("tau_s = 600.0", "tau_s = -1.0")).unwrap_err();
        assert!(e.to_string().starts_with(&format!("{deep}:")), "{e}");
        let hold = FB.replace("tau_s = 600.0", "tau_s = 1.7976931348623157e308");
        assert_ne!(hold, FB);
        parse("fb.toml", &hold).unwrap_or_else(|e| panic!("{e}"));
    }
}
