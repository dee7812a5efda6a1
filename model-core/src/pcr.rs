//! Principal component regression (seed 003, Eq. 4-6, 13-16).
//!
//! Correlated temperatures make least-squares weights unstable
//! (multicollinearity); PCR regresses on a few principal components instead.
//! The blob keeps the PCR form as the paper prints it: each component is an
//! affine map of the raw inputs, `C_j = c_j + sum_i w_ji x_i` (Eq. 14, the
//! standardisation folded in), and each output is
//! `y = beta_0 + sum_j beta_j C_j` (Eq. 13). Optionally `y` is the slope of a
//! positioning error, `poly(P) + (y - k0) P` (Eq. 16).

use crate::capacity::{MAX_CHANNELS, MAX_OUTPUTS};
use crate::position::PositionTerm;
use serde::{Deserialize, Serialize};

/// Principal components: seed 003 keeps one (85 % of the variance); eight
/// leave room for weakly correlated sensor sets.
pub const MAX_COMPONENTS: usize = 8;

/// One principal component in raw input units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Component {
    /// Constant `c_j` (absorbs the inputs' means and scales).
    pub intercept: f64,
    /// Weights `w_ji`, one per input of the owning [`Pcr`].
    #[serde(deserialize_with = "crate::wire::list")]
    pub weights: heapless::Vec<f64, MAX_CHANNELS>,
}

/// The regression of one output on the components.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PcrOutput {
    /// Index of the model output.
    pub output: u8,
    /// `beta_0`.
    pub intercept: f64,
    /// `beta_j`, one per component of the owning [`Pcr`] (0 for a component
    /// this output does not use).
    #[serde(deserialize_with = "crate::wire::list")]
    pub beta: heapless::Vec<f64, MAX_COMPONENTS>,
    /// Positioning-error form, when the regression gives a slope.
    pub position: Option<PositionTerm>,
}

impl PcrOutput {
    /// `beta_0 + sum_j beta_j C_j` for the component scores `c`.
    fn regression(&self, c: &[f64]) -> f64 {
        self.beta
            .iter()
            .zip(c)
            .fold(self.intercept, |acc, (b, cj)| acc + b * cj)
    }
}

/// Principal components shared by every output, and one regression per
/// output on them. Sharing is how PCR is fitted (the components come from
/// the inputs alone) and keeps the hub's copy small; a spec with different
/// components per output is merged into this form exactly (each output's
/// betas are zero on the others' components).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pcr {
    /// Input channels, in the order of each component's weights.
    #[serde(deserialize_with = "crate::wire::list")]
    pub inputs: heapless::Vec<u8, MAX_CHANNELS>,
    /// The components.
    pub components: heapless::Vec<Component, MAX_COMPONENTS>,
    /// One regression per output.
    pub outputs: heapless::Vec<PcrOutput, MAX_OUTPUTS>,
}

impl Pcr {
    /// `C_j(x) = c_j + sum_i w_ji x_i` for every component (seed 003,
    /// Eq. 13); entries past the model's components are 0.
    pub fn scores(&self, x: &[f64]) -> [f64; MAX_COMPONENTS] {
        let mut c = [0.0; MAX_COMPONENTS];
        for (cj, comp) in c.iter_mut().zip(&self.components) {
            *cj = comp
                .weights
                .iter()
                .zip(&self.inputs)
                .fold(comp.intercept, |acc, (w, ch)| {
                    acc + w * x.get(usize::from(*ch)).copied().unwrap_or(0.0)
                });
        }
        c
    }

    /// Runs every output on the (reference-adjusted) inputs `x`, calling
    /// `emit(output, value)`.
    pub fn evaluate(&self, x: &[f64], mut emit: impl FnMut(u8, f64)) {
        let c = self.scores(x);
        for eq in &self.outputs {
            let k = eq.regression(&c);
            let y = match &eq.position {
                Some(pos) => pos.error(k, x.get(usize::from(pos.channel)).copied().unwrap_or(0.0)),
                None => k,
            };
            emit(eq.output, y);
        }
    }

    /// For each positional output, `emit(output, k - k0)`: the thermal
    /// slope ([`PositionTerm::thermal_slope`]) at the inputs `x`.
    pub fn slopes(&self, x: &[f64], mut emit: impl FnMut(u8, f64)) {
        let c = self.scores(x);
        for eq in &self.outputs {
            if let Some(pos) = &eq.position {
                emit(eq.output, pos.thermal_slope(eq.regression(&c)));
            }
        }
    }

    /// Output `eq`'s regression collapsed to `d0 + sum_i d_i x_i` (seed 003
    /// Eq. 15 from Eq. 13 and 14): `d0 = beta_0 + sum_j beta_j c_j`,
    /// `d_i = sum_j beta_j w_ji`. Coefficients follow `inputs`.
    pub fn equivalent_linear(&self, eq: &PcrOutput) -> (f64, heapless::Vec<f64, MAX_CHANNELS>) {
        let mut d0 = eq.intercept;
        let mut d: heapless::Vec<f64, MAX_CHANNELS> = heapless::Vec::new();
        for _ in &self.inputs {
            // Capacity equals MAX_CHANNELS, the bound of `inputs`.
            let _ = d.push(0.0);
        }
        for (comp, beta) in self.components.iter().zip(&eq.beta) {
            d0 += beta * comp.intercept;
            for (di, w) in d.iter_mut().zip(&comp.weights) {
                *di += beta * w;
            }
        }
        (d0, d)
    }
}
