//! What a blob holds, as text for people and JSON for scripts, including
//! what validation derived (TF poles, cancellations, steady-state gains, the
//! collapsed linear form of a PCR).

use model_core::arma::Arma;
use model_core::blob::{crc32, HEADER_LEN, TRAILER_LEN};
use model_core::bp::BpNet;
use model_core::fbank::FilterBank;
use model_core::linear::Linear;
use model_core::pcr::Pcr;
use model_core::poly::{self, Complex};
use model_core::position::PositionTerm;
use model_core::tf::TfEntry;
use model_core::{Params, Reference, ValidModel};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

fn reference_json(r: Reference) -> Value {
    match r {
        Reference::Absolute => json!("absolute"),
        Reference::First => json!("first"),
        Reference::Value(v) => json!(v),
    }
}

fn reference_text(r: Reference) -> String {
    match r {
        Reference::Absolute => "absolute".into(),
        Reference::First => "minus its first sample".into(),
        Reference::Value(v) => format!("minus {v}"),
    }
}

/// Roots with imaginary parts below root-finding noise shown as real.
fn roots(c: &[f64]) -> Vec<Complex> {
    poly::roots(c)
        .map(|r| {
            r.as_slice()
                .iter()
                .map(|z| {
                    let im = if z.im.abs() < 1e-9 * (1.0 + z.re.abs()) {
                        0.0
                    } else {
                        z.im
                    };
                    Complex::new(z.re, im)
                })
                .collect()
        })
        .unwrap_or_default()
}

fn complex_json(z: &[Complex]) -> Value {
    Value::Array(
        z.iter()
            .map(|z| {
                if z.im == 0.0 {
                    json!(z.re)
                } else {
                    json!([z.re, z.im])
                }
            })
            .collect(),
    )
}

fn complex_text(z: &[Complex]) -> String {
    if z.is_empty() {
        return "none".into();
    }
    z.iter()
        .map(|z| {
            if z.im == 0.0 {
                format!("{:.6}", z.re)
            } else {
                format!("{:.6}{:+.6}i", z.re, z.im)
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// What a blob's header and trailer say: kind, format version, CRC, sample
/// time (`model show`'s first lines).
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Model kind.
    pub kind: &'static str,
    /// Blob format version.
    pub format_version: u16,
    /// CRC-32 of the blob, `0x` and eight hex digits.
    pub crc32: String,
    /// Sample time, s.
    pub dt_s: f64,
}

impl Header {
    /// The header of `bytes`, the encoding of `model`.
    pub fn of(model: &ValidModel, bytes: &[u8]) -> Header {
        Header {
            kind: model.kind().name(),
            format_version: format_version(bytes),
            crc32: crc_text(bytes),
            dt_s: model.model().dt_s,
        }
    }
}

/// The blob's CRC-32 (over everything but the trailer) as printed.
fn crc_text(bytes: &[u8]) -> String {
    format!(
        "{:#010x}",
        crc32(&bytes[..bytes.len().saturating_sub(TRAILER_LEN)])
    )
}

/// The format version in the blob's header (version 1 blobs still load).
fn format_version(bytes: &[u8]) -> u16 {
    match bytes.get(4..6) {
        Some(&[lo, hi]) => u16::from_le_bytes([lo, hi]),
        _ => 0,
    }
}

/// Time constants as people read them.
fn tau_text(tau_s: f64) -> String {
    if tau_s == 0.0 {
        "unfiltered".into()
    } else if tau_s >= 3600.0 {
        format!("tau {:.4} h", tau_s / 3600.0)
    } else if tau_s >= 60.0 {
        format!("tau {:.4} min", tau_s / 60.0)
    } else {
        format!("tau {tau_s} s")
    }
}

fn bounds_json(model: &ValidModel) -> Value {
    match model.bounds() {
        None => Value::Null,
        Some(b) => json!({
            "envelope": model.inputs().iter().zip(&b.envelope).map(|(c, s)| json!({
                "input": c.name.as_str(), "min": s.min, "max": s.max})).collect::<Vec<_>>(),
            "half_width": model.outputs().iter().zip(&b.half_width).zip(&b.growth).map(|((o, h), g)| json!({
                "output": o.as_str(), "half_width": h, "growth": g})).collect::<Vec<_>>(),
            "extrapolation_flag_at": ValidModel::EXTRAPOLATION_FLAG_AT,
        }),
    }
}

fn name_of(names: &[model_core::Name], i: u8) -> &str {
    names.get(usize::from(i)).map_or("?", |n| n.as_str())
}

fn input_of(model: &ValidModel, i: u8) -> &str {
    model
        .inputs()
        .get(usize::from(i))
        .map_or("?", |c| c.name.as_str())
}

/// A TF bank's entries: coefficients, poles and zeros, the realised transfer function.
fn tf_json(model: &ValidModel, entries: &[TfEntry]) -> Value {
    Value::Array(
        entries
            .iter()
            .zip(model.realised_tfs())
            .map(|(e, r)| {
                json!({
                    "output": name_of(model.outputs(), e.output),
                    "input": input_of(model, e.input),
                    "a": e.a.as_slice(),
                    "b": e.b.as_slice(),
                    "poles": complex_json(&roots(&e.b)),
                    "zeros": complex_json(&roots(&e.a)),
                    "cancelled_pairs": r.cancelled(),
                    "realised_num": r.numerator(),
                    "realised_den": r.denominator(),
                    "steady_state_gain": r.dc_gain(),
                })
            })
            .collect(),
    )
}

/// A linear model's equations, a coefficient per input name.
fn linear_json(model: &ValidModel, lin: &Linear) -> Value {
    Value::Array(
        lin.outputs
            .iter()
            .map(|eq| {
                let coef: serde_json::Map<String, Value> = eq
                    .coef
                    .iter()
                    .map(|c| (input_of(model, c.channel).to_string(), json!(c.value)))
                    .collect();
                json!({
                    "output": name_of(model.outputs(), eq.output),
                    "intercept": eq.intercept,
                    "coef": coef,
                    "position": eq.position.as_ref().map(|p| position_json(model, p)),
                })
            })
            .collect(),
    )
}

/// A PCR model: inputs, components, and each output's equation on the components and as the equivalent linear one.
fn pcr_json(model: &ValidModel, pcr: &Pcr) -> Value {
    let inputs: Vec<&str> = pcr.inputs.iter().map(|c| input_of(model, *c)).collect();
    json!({
        "inputs": inputs,
        "components": pcr.components.iter().map(|c| json!({
            "intercept": c.intercept, "weights": c.weights.as_slice()})).collect::<Vec<_>>(),
        "outputs": pcr.outputs.iter().map(|eq| {
            let (d0, d) = pcr.equivalent_linear(eq);
            let collapsed: serde_json::Map<String, Value> = inputs
                .iter()
                .zip(&d)
                .map(|(n, v)| ((*n).to_string(), json!(v)))
                .collect();
            json!({
                "output": name_of(model.outputs(), eq.output),
                "intercept": eq.intercept,
                "beta": eq.beta.as_slice(),
                "equivalent_linear": {"intercept": d0, "coef": collapsed},
                "position": eq.position.as_ref().map(|p| position_json(model, p)),
            })
        }).collect::<Vec<_>>(),
    })
}

/// A BP network's layers and scaling.
fn bp_json(model: &ValidModel, net: &BpNet) -> Value {
    json!({
        "inputs": net.inputs.iter().map(|c| input_of(model, *c)).collect::<Vec<_>>(),
        "outputs": net.outputs.iter().map(|o| name_of(model.outputs(), *o)).collect::<Vec<_>>(),
        "hidden": net.hidden(),
        "hidden_activation": net.hidden_activation.name(),
        "output_activation": net.output_activation.name(),
        "w1": net.w1.as_slice(), "b1": net.b1.as_slice(),
        "w2": net.w2.as_slice(), "b2": net.b2.as_slice(),
        "x_min": net.x_min.as_slice(), "x_max": net.x_max.as_slice(),
        "y_min": net.y_min.as_slice(), "y_max": net.y_max.as_slice(),
    })
}

/// An ARMA model's order, standardisation and coefficients.
fn arma_json(model: &ValidModel, a: &Arma) -> Value {
    json!({
        "series": input_of(model, a.channel),
        "output": name_of(model.outputs(), a.output),
        "p": a.phi.len(), "d": a.diff, "q": a.theta.len(),
        "mean": a.mean, "std": a.std, "constant": a.constant,
        "phi": a.phi.as_slice(), "theta": a.theta.as_slice(),
    })
}

/// A filter bank's features (with their poles) and output equations.
fn fbank_json(model: &ValidModel, bank: &FilterBank) -> Value {
    json!({
        "features": bank.features.iter().zip(model.fbank_poles()).map(|(f, p)| json!({
            "input": input_of(model, f.input), "power": f.power, "tau_s": f.tau_s,
            "pole": p})).collect::<Vec<_>>(),
        "outputs": bank.outputs.iter().map(|eq| json!({
            "output": name_of(model.outputs(), eq.output),
            "intercept": eq.intercept,
            "coef": eq.coef.as_slice(),
        })).collect::<Vec<_>>(),
    })
}

/// The coefficients of the blob's kind, as JSON (one shape per kind).
fn coefficients_json(model: &ValidModel) -> Value {
    match &model.model().params {
        Params::Tf(entries) => tf_json(model, entries),
        Params::Linear(lin) => linear_json(model, lin),
        Params::Pcr(pcr) => pcr_json(model, pcr),
        Params::Bp(net) => bp_json(model, net),
        Params::Arma(a) => arma_json(model, a),
        Params::Fbank(bank) => fbank_json(model, bank),
    }
}

/// The blob as one JSON object.
pub fn describe_json(model: &ValidModel, bytes: &[u8]) -> Value {
    let m = model.model();
    let coefficients = coefficients_json(model);
    json!({
        "kind": model.kind().name(),
        "format_version": format_version(bytes),
        "bytes": bytes.len(),
        "body_bytes": bytes.len().saturating_sub(HEADER_LEN + TRAILER_LEN),
        "crc32": crc_text(bytes),
        "dt_s": m.dt_s,
        "inputs": model.inputs().iter().map(|c| json!({
            "name": c.name.as_str(), "reference": reference_json(c.reference)})).collect::<Vec<_>>(),
        "outputs": model.outputs().iter().map(|o| o.as_str()).collect::<Vec<_>>(),
        "coefficients": coefficients,
        "bounds": bounds_json(model),
        "five_point": model.five_point().map(|t| json!({
            "l_defl_mm": t.l_defl_mm(), "lanes": model_core::fivepoint::TIP_OUTPUTS})),
    })
}

fn position_json(model: &ValidModel, p: &PositionTerm) -> Value {
    json!({"input": input_of(model, p.channel), "poly": p.poly.as_slice(), "k0": p.k0})
}

/// `lhs = rhs`, or, with a position term, `k = rhs` and the positioning error.
fn regression_text(
    s: &mut String,
    model: &ValidModel,
    lhs: &str,
    rhs: &str,
    position: Option<&PositionTerm>,
) {
    match position {
        None => {
            let _ = writeln!(s, "  {lhs} = {rhs}");
        }
        Some(p) => {
            let pos = input_of(model, p.channel);
            let _ = writeln!(s, "  k = {rhs}");
            let _ = writeln!(
                s,
                "  {lhs} = poly({pos}) + (k - {}) * {pos}, poly = {}",
                p.k0,
                list(&p.poly)
            );
        }
    }
}

fn list(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x}")).collect();
    format!("[{}]", parts.join(", "))
}

/// A TF bank's entries: coefficients, poles and zeros, the realised transfer function.
fn tf_text(s: &mut String, model: &ValidModel, entries: &[TfEntry]) {
    for (i, (e, r)) in entries.iter().zip(model.realised_tfs()).enumerate() {
        let _ = writeln!(
            s,
            "  tf {}: {} <- {}",
            i + 1,
            name_of(model.outputs(), e.output),
            input_of(model, e.input)
        );
        let _ = writeln!(s, "    a = {}", list(&e.a));
        let _ = writeln!(s, "    b = {}", list(&e.b));
        let _ = writeln!(s, "    poles {}", complex_text(&roots(&e.b)));
        let _ = writeln!(s, "    zeros {}", complex_text(&roots(&e.a)));
        if r.cancelled() > 0 {
            let _ = writeln!(
                s,
                "    {} pole/zero pair(s) on the unit circle cancelled; runs as num {} / den {}",
                r.cancelled(),
                list(r.numerator()),
                list(r.denominator())
            );
        }
        let _ = writeln!(s, "    steady-state gain {:.6}", r.dc_gain());
    }
}

/// A linear model's equations.
fn linear_text(s: &mut String, model: &ValidModel, lin: &Linear) {
    for eq in &lin.outputs {
        let mut line = format!("{}", eq.intercept);
        for c in &eq.coef {
            let _ = write!(line, " {:+} {}", c.value, input_of(model, c.channel));
        }
        let lhs = name_of(model.outputs(), eq.output);
        regression_text(s, model, lhs, &line, eq.position.as_ref());
    }
}

/// A PCR model's components and each output's equation on them and as the equivalent linear one.
fn pcr_text(s: &mut String, model: &ValidModel, pcr: &Pcr) {
    let inputs: Vec<&str> = pcr.inputs.iter().map(|c| input_of(model, *c)).collect();
    for (j, c) in pcr.components.iter().enumerate() {
        let mut line = format!("{}", c.intercept);
        for (w, n) in c.weights.iter().zip(&inputs) {
            let _ = write!(line, " {w:+} {n}");
        }
        let _ = writeln!(s, "  C{} = {line}", j + 1);
    }
    for eq in &pcr.outputs {
        let lhs = name_of(model.outputs(), eq.output);
        let mut line = format!("{}", eq.intercept);
        for (j, b) in eq.beta.iter().enumerate() {
            let _ = write!(line, " {b:+} C{}", j + 1);
        }
        let (d0, d) = pcr.equivalent_linear(eq);
        let mut collapsed = format!("{d0:.6}");
        for (v, n) in d.iter().zip(&inputs) {
            let _ = write!(collapsed, " {v:+.6} {n}");
        }
        let _ = write!(line, "\n    = {collapsed}");
        regression_text(s, model, lhs, &line, eq.position.as_ref());
    }
}

/// A BP network's shape, scaling and weights.
fn bp_text(s: &mut String, net: &BpNet) {
    let _ = writeln!(
        s,
        "  network {}-{}-{}, hidden {}, output {}, mapminmax scaling to [-1, 1]",
        net.inputs.len(),
        net.hidden(),
        net.outputs.len(),
        net.hidden_activation.name(),
        net.output_activation.name()
    );
    let _ = writeln!(
        s,
        "    x_min {}  x_max {}",
        list(&net.x_min),
        list(&net.x_max)
    );
    let _ = writeln!(
        s,
        "    y_min {}  y_max {}",
        list(&net.y_min),
        list(&net.y_max)
    );
    let _ = writeln!(s, "    w1 {}", list(&net.w1));
    let _ = writeln!(s, "    b1 {}", list(&net.b1));
    let _ = writeln!(s, "    w2 {}", list(&net.w2));
    let _ = writeln!(s, "    b2 {}", list(&net.b2));
}

/// An ARMA model's order, standardisation and coefficients.
fn arma_text(s: &mut String, a: &Arma) {
    let _ = writeln!(
        s,
        "  ARMA({}, {}) on the {}-times differenced series, standardised by mean {} std {}",
        a.phi.len(),
        a.theta.len(),
        a.diff,
        a.mean,
        a.std
    );
    let _ = writeln!(
        s,
        "    constant {}  phi {}  theta {}",
        a.constant,
        list(&a.phi),
        list(&a.theta)
    );
}

/// A filter bank's features and output equations.
fn fbank_text(s: &mut String, model: &ValidModel, bank: &FilterBank) {
    let _ = writeln!(s, "  features ({}):", bank.features.len());
    for (j, (f, p)) in bank.features.iter().zip(model.fbank_poles()).enumerate() {
        let x = input_of(model, f.input);
        let v = if f.power == 2 {
            format!("{x}^2")
        } else {
            x.to_string()
        };
        if f.tau_s == 0.0 {
            let _ = writeln!(s, "    s{} = {v} ({})", j + 1, tau_text(f.tau_s));
        } else if *p == 1.0 {
            // A pole of exactly 1 keeps the first value (fbank.rs, "hold").
            let _ = writeln!(
                s,
                "    s{} = {v} held at the run's first sample (pole 1)",
                j + 1
            );
        } else {
            let _ = writeln!(
                s,
                "    s{} = low-pass({v}), {}, pole {p:.8}",
                j + 1,
                tau_text(f.tau_s)
            );
        }
    }
    for eq in &bank.outputs {
        let mut line = format!("{}", eq.intercept);
        for (j, c) in eq.coef.iter().enumerate() {
            let _ = write!(line, " {c:+} s{}", j + 1);
        }
        let _ = writeln!(s, "  {} = {line}", name_of(model.outputs(), eq.output));
    }
}

/// The coefficients of the blob's kind, as text (one section per kind).
fn params_text(s: &mut String, model: &ValidModel) {
    match &model.model().params {
        Params::Tf(entries) => tf_text(s, model, entries),
        Params::Linear(lin) => linear_text(s, model, lin),
        Params::Pcr(pcr) => pcr_text(s, model, pcr),
        Params::Bp(net) => bp_text(s, net),
        Params::Arma(a) => arma_text(s, a),
        Params::Fbank(bank) => fbank_text(s, model, bank),
    }
}

/// The blob as text for a person.
pub fn describe_text(path: &Path, model: &ValidModel, bytes: &[u8]) -> String {
    let m = model.model();
    let mut s = String::new();
    let crc = crc32(&bytes[..bytes.len().saturating_sub(TRAILER_LEN)]);
    let _ = writeln!(s, "{} ({} bytes)", path.display(), bytes.len());
    let _ = writeln!(
        s,
        "  kind {}, blob format version {}, CRC-32 {crc:#010x} (ok)",
        model.kind().name(),
        format_version(bytes)
    );
    if model.kind().is_dynamic() {
        let _ = writeln!(s, "  sample time {} s", m.dt_s);
    }
    let _ = writeln!(s, "  inputs:");
    for c in model.inputs() {
        let _ = writeln!(
            s,
            "    {:<12} {}",
            c.name.as_str(),
            reference_text(c.reference)
        );
    }
    let outs: Vec<&str> = model.outputs().iter().map(|o| o.as_str()).collect();
    let _ = writeln!(s, "  outputs: {}", outs.join(", "));
    params_text(&mut s, model);
    if let Some(t) = model.five_point() {
        let _ = writeln!(
            s,
            "  five-point: deflection centre {} mm above the nose; the hub sends dx_um, dy_um, dz_um at the tool tip (docs/fivepoint.md)",
            t.l_defl_mm()
        );
    }
    match model.bounds() {
        None => {
            let _ = writeln!(s, "  bounds: none");
        }
        Some(b) => {
            let _ = writeln!(
                s,
                "  bounds (flag when an input is more than {} % of its range outside):",
                ValidModel::EXTRAPOLATION_FLAG_AT * 100.0
            );
            for (c, span) in model.inputs().iter().zip(&b.envelope) {
                let _ = writeln!(
                    s,
                    "    {:<12} calibrated on [{}, {}]",
                    c.name.as_str(),
                    span.min,
                    span.max
                );
            }
            for ((o, h), g) in model.outputs().iter().zip(&b.half_width).zip(&b.growth) {
                let _ = writeln!(
                    s,
                    "    {:<12} 95 % error band +-{h} x (1 + {g} x extrapolation)",
                    o.as_str()
                );
            }
        }
    }
    s
}
