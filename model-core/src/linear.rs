//! Linear regression of displacement on temperatures (seed 002, Eq. 2-6).
//!
//! `y = a0 + sum_i a_i x_i`, one equation per output, as the hobbing-machine
//! model `x_m = -0.2565 + 0.0189 T3 - 0.0124 T4 + 0.0082 T10 - 0.0074 T12`
//! prints it. With a [`PositionTerm`] the regression predicts the slope `k` of
//! a feed axis' positioning error instead (seed 003, Eq. 18).

use crate::capacity::MAX_CHANNELS;
use crate::position::PositionTerm;
use serde::{Deserialize, Serialize};

/// One regression coefficient: `value * input[channel]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Coef {
    /// Input channel index.
    pub channel: u8,
    /// Weight (output units per input unit).
    pub value: f64,
}

/// The regression equation of one output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearOutput {
    /// Index of the model output.
    pub output: u8,
    /// Constant term `a0`.
    pub intercept: f64,
    /// Weights `a_i` of the input channels.
    pub coef: heapless::Vec<Coef, MAX_CHANNELS>,
    /// When present, the regression gives the slope `k` of a positioning
    /// error and the output is `poly(P) + (k - k0) P`.
    pub position: Option<PositionTerm>,
}

impl LinearOutput {
    /// The regression value `a0 + sum a_i x_i` (the slope when positional).
    pub fn regression(&self, x: &[f64]) -> f64 {
        self.coef.iter().fold(self.intercept, |acc, c| {
            acc + c.value * x.get(usize::from(c.channel)).copied().unwrap_or(0.0)
        })
    }

    /// The thermal slope `k - k0` ([`PositionTerm::thermal_slope`]) at the
    /// (reference-adjusted) inputs `x`, if this output is positional.
    pub fn slope(&self, x: &[f64]) -> Option<f64> {
        self.position
            .as_ref()
            .map(|pos| pos.thermal_slope(self.regression(x)))
    }

    /// The output for the (reference-adjusted) inputs `x`.
    pub fn evaluate(&self, x: &[f64]) -> f64 {
        let k = self.regression(x);
        match &self.position {
            Some(pos) => pos.error(k, x.get(usize::from(pos.channel)).copied().unwrap_or(0.0)),
            None => k,
        }
    }
}

/// A set of linear regressions, one per output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Linear {
    /// The equations.
    pub outputs: heapless::Vec<LinearOutput, { crate::capacity::MAX_OUTPUTS }>,
}
