//! Multiple linear regression (seed 002, Eq. 2-6): one least-squares
//! equation per target on the calibration rows, written as a `linear` model.

use super::{channels, outputs, Details, Fitted};
use crate::data::dataset::Dataset;
use crate::num::linalg;
use anyhow::{anyhow, Result};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::{Model, Params};
use serde::Serialize;
use std::collections::BTreeMap;

/// What `mlr` reports (fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MlrDetails {
    /// Per target, its equation.
    pub equations: BTreeMap<String, MlrEquation>,
    /// How the least squares were solved.
    pub solver: &'static str,
}

/// One target's equation `y = intercept + sum coef_i x_i`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MlrEquation {
    /// Per input, its coefficient (target unit per input unit, um/K for a temperature).
    pub coef: BTreeMap<String, f64>,
    /// Intercept (target unit).
    pub intercept: f64,
}

/// Fits `y_k = a0 + sum a_i x_i` for every target.
pub fn fit(ds: &Dataset) -> Result<Fitted> {
    let m = ds.inputs.len();
    let mut equations = heapless::Vec::new();
    let mut reported = BTreeMap::new();
    for (k, target) in ds.targets.iter().enumerate() {
        let (b0, b) = linalg::least_squares_visit(m, &mut |f| {
            ds.visit_calibration_rows(&mut |x, y| f(x, y[k]));
        })?;
        let mut coef = heapless::Vec::new();
        for (i, value) in b.iter().enumerate() {
            coef.push(Coef {
                channel: u8::try_from(i)?,
                value: *value,
            })
            .map_err(|_| anyhow!("too many inputs"))?;
        }
        let coef_named = ds.inputs.iter().cloned().zip(b.iter().copied()).collect();
        reported.insert(
            target.clone(),
            MlrEquation {
                coef: coef_named,
                intercept: b0,
            },
        );
        equations
            .push(LinearOutput {
                output: u8::try_from(k)?,
                intercept: b0,
                coef,
                position: None,
            })
            .map_err(|_| anyhow!("too many targets"))?;
    }
    let model = Model {
        inputs: channels(ds)?,
        outputs: outputs(ds)?,
        dt_s: 0.0,
        params: Params::Linear(Linear { outputs: equations }),
        bounds: None,
        five_point: None,
    }
    .validate()
    .map_err(|e| anyhow!("fitted model refused: {e}"))?;
    let details = MlrDetails {
        equations: reported,
        solver: "blocked QR of centred, scaled columns, SVD of R",
    };
    Ok(Fitted {
        model,
        details: Details::Mlr(details),
    })
}
