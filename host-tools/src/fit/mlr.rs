//! Multiple linear regression (seed 002, Eq. 2-6): one least-squares
//! equation per target on the calibration rows, written as a `linear` model.

use super::{channels, outputs, Fitted};
use crate::data::dataset::Dataset;
use crate::num::linalg;
use anyhow::{anyhow, Result};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::{Model, Params};
use serde_json::{json, Map, Value};

/// Fits `y_k = a0 + sum a_i x_i` for every target.
pub fn fit(ds: &Dataset) -> Result<Fitted> {
    let m = ds.inputs.len();
    let mut equations = heapless::Vec::new();
    let mut details = Map::new();
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
        let named: Map<String, Value> = ds
            .inputs
            .iter()
            .zip(&b)
            .map(|(n, v)| (n.clone(), json!(v)))
            .collect();
        details.insert(target.clone(), json!({"intercept": b0, "coef": named}));
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
    Ok(Fitted {
        model,
        details: json!({"solver": "blocked QR of centred, scaled columns, SVD of R", "equations": details}),
    })
}
