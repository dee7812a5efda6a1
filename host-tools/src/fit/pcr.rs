//! Principal component regression (seed 003, Eq. 4-6 and 13-14).
//!
//! The calibration inputs are standardised, the correlation matrix is
//! eigen-decomposed, and the components that explain a chosen share of the
//! variance (85 % by default, as seed 003 chose by cumulative percentage) or
//! a chosen count are kept; each target is regressed on them. The blob keeps
//! the PCR form, with the standardisation folded into each component:
//! `C_j = c_j + sum_i w_ji x_i`, `w_ji = v_ij / s_i`, `c_j = -sum_i v_ij m_i / s_i`.

use super::{channels, outputs, Details, Fitted};
use crate::data::dataset::Dataset;
use crate::num::linalg;
use anyhow::{anyhow, bail, Result};
use model_core::model::MAX_OUTPUTS;
use model_core::pcr::{Component, Pcr, PcrOutput, MAX_COMPONENTS};
use model_core::{Model, Params};
use nalgebra::DMatrix;
use serde::Serialize;
use std::collections::BTreeMap;

/// PCR options (`fit --model pcr`); [`Default`] is `fit`'s defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct PcrOptions {
    /// pcr: keep the fewest components whose cumulative share of the
    /// variance reaches this fraction (seed 003: 0.85).
    pub variance: f64,
    /// pcr: keep exactly this many components instead.
    pub components: Option<usize>,
}

impl Default for PcrOptions {
    fn default() -> Self {
        Self {
            variance: 0.85,
            components: None,
        }
    }
}

impl PcrOptions {
    /// The variance share lies in (0, 1].
    pub fn check(&self) -> Result<()> {
        if !(self.variance > 0.0 && self.variance <= 1.0) {
            bail!("--variance {} must be in (0, 1]", self.variance);
        }
        Ok(())
    }
}

/// What `pcr` reports (fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PcrDetails {
    /// Components kept.
    pub components_kept: usize,
    /// Cumulative share of the variance, %, largest component first.
    pub cumulative_pct: Vec<f64>,
    /// Eigenvalues of the inputs' correlation matrix, largest first (clipped at 0).
    pub eigenvalues: Vec<f64>,
    /// Per target, its regression on the components.
    pub equations: BTreeMap<String, PcrEquation>,
    /// How many components were kept: `count` or the cumulative variance rule.
    pub rule: String,
    /// Each component's share of the variance, %.
    pub variance_pct: Vec<f64>,
}

/// One target's regression on the component scores.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PcrEquation {
    /// Coefficient per component kept (target unit per unit score).
    pub beta: Vec<f64>,
    /// The same equation on the raw inputs.
    pub equivalent_linear: EquivalentLinear,
    /// Intercept (target unit).
    pub intercept: f64,
}

/// A PCR equation written on the raw inputs: `y = intercept + sum coef_i x_i`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EquivalentLinear {
    /// Per input, in input order (target unit per input unit).
    pub coef: Vec<f64>,
    /// Intercept (target unit).
    pub intercept: f64,
}

/// The components of the standardised inputs, largest variance first:
/// eigenvalues (clipped at 0) and the matching eigenvector columns of `eig`.
fn ranked_components(eig: &nalgebra::SymmetricEigen<f64, nalgebra::Dyn>) -> (Vec<usize>, Vec<f64>) {
    let m = eig.eigenvalues.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|a, b| eig.eigenvalues[*b].total_cmp(&eig.eigenvalues[*a]));
    let values: Vec<f64> = order.iter().map(|&j| eig.eigenvalues[j].max(0.0)).collect();
    (order, values)
}

/// How many components to keep (of `m`): `--components`, or the fewest
/// whose cumulative `share` reaches `--variance`.
fn components_kept(args: &PcrOptions, share: &[f64], m: usize) -> Result<usize> {
    let k = match args.components {
        Some(0) => bail!("--components must be at least 1"),
        Some(k) if k > m => bail!("--components {k} exceeds the {m} inputs"),
        Some(k) => k,
        None => {
            let mut cum = 0.0;
            share
                .iter()
                .position(|s| {
                    cum += s;
                    cum >= args.variance - 1e-12
                })
                .map_or(m, |p| p + 1)
        }
    };
    if k > MAX_COMPONENTS {
        bail!("pcr: {k} components needed, the model holds at most {MAX_COMPONENTS} (use --components)");
    }
    Ok(k)
}

/// The kept eigenvectors `v` (`m x k`) as blob components on raw inputs:
/// the standardisation folded in, `w_ji = v_ij / s_i`,
/// `c_j = -sum_i w_ji m_i`.
fn folded_components(
    v: &DMatrix<f64>,
    mean: &[f64],
    std: &[f64],
) -> Result<heapless::Vec<Component, MAX_COMPONENTS>> {
    let (m, k) = (v.nrows(), v.ncols());
    let mut components = heapless::Vec::<Component, MAX_COMPONENTS>::new();
    for j in 0..k {
        let mut weights = heapless::Vec::new();
        let mut intercept = 0.0;
        for i in 0..m {
            // A constant input carries no information; give it no weight.
            let w = if std[i] > 0.0 {
                v[(i, j)] / std[i]
            } else {
                0.0
            };
            intercept -= w * mean[i];
            weights.push(w).map_err(|_| anyhow!("too many inputs"))?;
        }
        components
            .push(Component { intercept, weights })
            .map_err(|_| anyhow!("too many components"))?;
    }
    Ok(components)
}

/// Each target regressed on the component scores: the equations.
fn regress_targets(
    ds: &Dataset,
    y: &[Vec<f64>],
    score_rows: &[Vec<f64>],
) -> Result<heapless::Vec<PcrOutput, MAX_OUTPUTS>> {
    let mut equations = heapless::Vec::new();
    for t in 0..ds.targets.len() {
        let yt: Vec<f64> = y.iter().map(|r| r[t]).collect();
        let (b0, beta) = linalg::least_squares(score_rows, &yt)?;
        let eq = PcrOutput {
            output: u8::try_from(t)?,
            intercept: b0,
            beta: heapless::Vec::from_slice(&beta).map_err(|_| anyhow!("too many components"))?,
            position: None,
        };
        equations
            .push(eq)
            .map_err(|_| anyhow!("too many targets"))?;
    }
    Ok(equations)
}

/// The report of a fitted `pcr` (`values`: the eigenvalues, largest
/// first; `share`: each one's share of their sum).
fn pcr_details(
    ds: &Dataset,
    pcr: &Pcr,
    args: &PcrOptions,
    values: Vec<f64>,
    share: &[f64],
) -> PcrDetails {
    let equations = pcr
        .outputs
        .iter()
        .zip(&ds.targets)
        .map(|(eq, target)| {
            let (d0, d) = pcr.equivalent_linear(eq);
            let report = PcrEquation {
                beta: eq.beta.to_vec(),
                equivalent_linear: EquivalentLinear {
                    coef: d.to_vec(),
                    intercept: d0,
                },
                intercept: eq.intercept,
            };
            (target.clone(), report)
        })
        .collect();
    let cumulative_pct = share
        .iter()
        .scan(0.0, |c, s| {
            *c += s;
            Some(*c * 100.0)
        })
        .collect();
    PcrDetails {
        components_kept: pcr.components.len(),
        cumulative_pct,
        eigenvalues: values,
        equations,
        rule: if args.components.is_some() {
            "count".to_string()
        } else {
            format!("cumulative variance >= {}", args.variance)
        },
        variance_pct: share.iter().map(|s| s * 100.0).collect(),
    }
}

/// Fits a PCR per target on shared components.
pub fn fit(ds: &Dataset, args: &PcrOptions) -> Result<Fitted> {
    let (x, y) = ds.calibration_rows();
    let (n, m) = (x.len(), ds.inputs.len());
    if n <= m {
        bail!("pcr: {n} calibration rows for {m} inputs: not enough data");
    }
    let (mean, std) = linalg::moments(&x, m);
    let z = linalg::standardised(&x, &mean, &std);
    let corr = (z.transpose() * &z) / (n as f64 - 1.0);
    let eig = crate::num::decomp::symmetric_eigen(corr)?;
    let (order, values) = ranked_components(&eig);
    let total: f64 = values.iter().sum();
    if total <= 0.0 {
        bail!("pcr: every input is constant over the calibration rows");
    }
    let share: Vec<f64> = values.iter().map(|v| v / total).collect();
    let k = components_kept(args, &share, m)?;
    let v = DMatrix::from_fn(m, k, |i, j| eig.eigenvectors[(i, order[j])]);
    let scores = &z * &v;
    let score_rows: Vec<Vec<f64>> = (0..n)
        .map(|r| scores.row(r).iter().copied().collect())
        .collect();
    let components = folded_components(&v, &mean, &std)?;
    let equations = regress_targets(ds, &y, &score_rows)?;
    let pcr = Pcr {
        inputs: (0..m).map(u8::try_from).collect::<Result<_, _>>()?,
        components,
        outputs: equations,
    };
    let details = pcr_details(ds, &pcr, args, values, &share);
    let model = Model {
        inputs: channels(ds)?,
        outputs: outputs(ds)?,
        dt_s: 0.0,
        params: Params::Pcr(pcr),
        bounds: None,
        five_point: None,
    }
    .validate()
    .map_err(|e| anyhow!("fitted model refused: {e}"))?;
    Ok(Fitted {
        model,
        details: Details::Pcr(details),
    })
}
