//! Principal component regression (seed 003, Eq. 4-6, 13-16).
//!
//! Correlated temperatures make least-squares weights unstable
//! (multicollinearity); PCR regresses on a few principal components instead.
//! The blob keeps the PCR form as the paper prints it: each component is an
//! affine map of the raw inputs, `C_j = c_j + sum_i w_ji x_i` (Eq. 14, the
//! standardisation folded in), and the output is
//! `y = beta_0 + sum_j beta_j C_j` (Eq. 13). Optionally `y` is the slope of a
//! positioning error, `poly(P) + (y - k0) P` (Eq. 16).

use crate::model::{MAX_CHANNELS, MAX_OUTPUTS};
use crate::position::PositionTerm;
use serde::{Deserialize, Serialize};

/// Principal components kept per output: seed 003 keeps one (85 % of the
/// variance); four leave room for less collinear sensor sets.
pub const MAX_COMPONENTS: usize = 4;

/// One principal component in raw input units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Component {
    /// Constant `c_j` (absorbs the inputs' means and scales).
    pub intercept: f64,
    /// Weights `w_ji`, one per input of the owning [`PcrOutput`].
    pub weights: heapless::Vec<f64, MAX_CHANNELS>,
}

/// The PCR equation of one output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PcrOutput {
    /// Index of the model output.
    pub output: u8,
    /// Input channels, in the order of each component's weights.
    pub inputs: heapless::Vec<u8, MAX_CHANNELS>,
    /// Retained components.
    pub components: heapless::Vec<Component, MAX_COMPONENTS>,
    /// `beta_0`.
    pub intercept: f64,
    /// `beta_j`, one per component.
    pub beta: heapless::Vec<f64, MAX_COMPONENTS>,
    /// Positioning-error form, when the regression gives a slope.
    pub position: Option<PositionTerm>,
}

impl PcrOutput {
    /// `beta_0 + sum_j beta_j C_j(x)`.
    pub fn regression(&self, x: &[f64]) -> f64 {
        let mut y = self.intercept;
        for (comp, beta) in self.components.iter().zip(&self.beta) {
            let c = comp
                .weights
                .iter()
                .zip(&self.inputs)
                .fold(comp.intercept, |acc, (w, ch)| {
                    acc + w * x.get(usize::from(*ch)).copied().unwrap_or(0.0)
                });
            y += beta * c;
        }
        y
    }

    /// The output for the (reference-adjusted) inputs `x`.
    pub fn evaluate(&self, x: &[f64]) -> f64 {
        let k = self.regression(x);
        match &self.position {
            Some(pos) => pos.error(k, x.get(usize::from(pos.channel)).copied().unwrap_or(0.0)),
            None => k,
        }
    }

    /// The same map collapsed to `y = d0 + sum_i d_i x_i` (seed 003 Eq. 15
    /// from Eq. 13 and 14): `d0 = beta_0 + sum_j beta_j c_j`,
    /// `d_i = sum_j beta_j w_ji`. Coefficients follow `inputs`.
    pub fn equivalent_linear(&self) -> (f64, heapless::Vec<f64, MAX_CHANNELS>) {
        let mut d0 = self.intercept;
        let mut d: heapless::Vec<f64, MAX_CHANNELS> = heapless::Vec::new();
        for _ in &self.inputs {
            // Capacity equals MAX_CHANNELS, the bound of `inputs`.
            let _ = d.push(0.0);
        }
        for (comp, beta) in self.components.iter().zip(&self.beta) {
            d0 += beta * comp.intercept;
            for (di, w) in d.iter_mut().zip(&comp.weights) {
                *di += beta * w;
            }
        }
        (d0, d)
    }
}

/// A set of PCR equations, one per output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pcr {
    /// The equations.
    pub outputs: heapless::Vec<PcrOutput, MAX_OUTPUTS>,
}
