//! Forward pass of a one-hidden-layer back-propagation network (seeds 000, 003).
//!
//! The papers trained MATLAB feed-forward nets (`newff`/`feedforwardnet`), so
//! this reproduces MATLAB's forward pass exactly: inputs scaled by
//! `mapminmax` to [-1, 1], `h = f1(W1 x + b1)` with `tansig` or `logsig`,
//! `o = f2(W2 h + b2)` with `purelin` (or a sigmoid), and the outputs mapped
//! back from [-1, 1] to engineering units. A blob trained elsewhere can be
//! written by hand from MATLAB's `net.IW`, `net.b`, `net.LW` and the
//! `mapminmax` settings (`xmin`, `xmax`).

use crate::capacity::{MAX_CHANNELS, MAX_OUTPUTS};
use serde::{Deserialize, Serialize};

/// Hidden neurons at most.
pub const MAX_HIDDEN: usize = 32;
/// Input-to-hidden weights at most (m x n): any net of the papers' size
/// (seed 000: 4-11-3) and up to 16 inputs x 24 hidden or 24 x 16 fits, while
/// the model stays a few KiB of the hub's RAM.
pub const MAX_W1: usize = 384;
/// Hidden-to-output weights at most.
pub const MAX_W2: usize = MAX_HIDDEN * MAX_OUTPUTS;

/// A layer's transfer function, by MATLAB's name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Activation {
    /// `tansig(n) = 2 / (1 + exp(-2n)) - 1`, i.e. `tanh`.
    Tansig,
    /// `logsig(n) = 1 / (1 + exp(-n))`.
    Logsig,
    /// `purelin(n) = n`.
    Purelin,
}

impl Activation {
    /// Applies the transfer function; saturates instead of overflowing.
    pub fn apply(self, n: f64) -> f64 {
        match self {
            Self::Tansig => libm::tanh(n),
            Self::Logsig => 1.0 / (1.0 + libm::exp(-n)),
            Self::Purelin => n,
        }
    }

    /// MATLAB's name of the function.
    pub fn name(self) -> &'static str {
        match self {
            Self::Tansig => "tansig",
            Self::Logsig => "logsig",
            Self::Purelin => "purelin",
        }
    }
}

/// The network: weights row-major (`w1[j * m + i]` joins input `i` to
/// hidden neuron `j`; `w2[k * n + j]` joins hidden `j` to output `k`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BpNet {
    /// Input channels (m of them), in weight order.
    #[serde(deserialize_with = "crate::wire::list")]
    pub inputs: heapless::Vec<u8, MAX_CHANNELS>,
    /// Model outputs fed (q of them), in weight order.
    #[serde(deserialize_with = "crate::wire::list")]
    pub outputs: heapless::Vec<u8, MAX_OUTPUTS>,
    /// Hidden-layer transfer function.
    pub hidden_activation: Activation,
    /// Output-layer transfer function (MATLAB's default is `purelin`).
    pub output_activation: Activation,
    /// n x m input weights.
    #[serde(deserialize_with = "crate::wire::list")]
    pub w1: heapless::Vec<f64, MAX_W1>,
    /// n hidden biases.
    #[serde(deserialize_with = "crate::wire::list")]
    pub b1: heapless::Vec<f64, MAX_HIDDEN>,
    /// q x n output weights.
    #[serde(deserialize_with = "crate::wire::list")]
    pub w2: heapless::Vec<f64, MAX_W2>,
    /// q output biases.
    #[serde(deserialize_with = "crate::wire::list")]
    pub b2: heapless::Vec<f64, MAX_OUTPUTS>,
    /// `mapminmax` input minima (m).
    #[serde(deserialize_with = "crate::wire::list")]
    pub x_min: heapless::Vec<f64, MAX_CHANNELS>,
    /// `mapminmax` input maxima (m).
    #[serde(deserialize_with = "crate::wire::list")]
    pub x_max: heapless::Vec<f64, MAX_CHANNELS>,
    /// `mapminmax` output minima (q).
    #[serde(deserialize_with = "crate::wire::list")]
    pub y_min: heapless::Vec<f64, MAX_OUTPUTS>,
    /// `mapminmax` output maxima (q).
    #[serde(deserialize_with = "crate::wire::list")]
    pub y_max: heapless::Vec<f64, MAX_OUTPUTS>,
}

/// `mapminmax` to [-1, 1]. MATLAB passes a constant row through with unit
/// gain (`xmax == xmin`), and so does this.
fn scale(x: f64, lo: f64, hi: f64) -> f64 {
    let span = hi - lo;
    if span == 0.0 {
        x - lo - 1.0
    } else {
        2.0 * (x - lo) / span - 1.0
    }
}

/// Inverse of [`scale`].
fn unscale(y: f64, lo: f64, hi: f64) -> f64 {
    let span = hi - lo;
    if span == 0.0 {
        y + 1.0 + lo
    } else {
        (y + 1.0) * span / 2.0 + lo
    }
}

impl BpNet {
    /// Hidden neurons `n`.
    pub fn hidden(&self) -> usize {
        self.b1.len()
    }

    /// The sizes agree with each other (`w1` is n x m, ...).
    pub fn shapes_agree(&self) -> bool {
        let (m, n, q) = (self.inputs.len(), self.hidden(), self.outputs.len());
        n > 0
            && m > 0
            && q > 0
            && self.w1.len() == n * m
            && self.w2.len() == q * n
            && self.b2.len() == q
            && self.x_min.len() == m
            && self.x_max.len() == m
            && self.y_min.len() == q
            && self.y_max.len() == q
            && self.x_min.iter().zip(&self.x_max).all(|(lo, hi)| lo <= hi)
            && self.y_min.iter().zip(&self.y_max).all(|(lo, hi)| lo <= hi)
    }

    /// Every weight, bias and scale is finite and within
    /// [`crate::capacity::MAX_MAGNITUDE`], the inputs' `mapminmax` gains
    /// `2 / span` too (a span of 1e-300 would multiply an input by 2e300;
    /// the outputs' spans only shrink).
    pub fn is_bounded(&self) -> bool {
        use crate::capacity::bounded;
        let gain_bounded = |(lo, hi): (&f64, &f64)| hi == lo || bounded(2.0 / (hi - lo));
        [
            &self.w1[..],
            &self.b1[..],
            &self.w2[..],
            &self.b2[..],
            &self.x_min[..],
            &self.x_max[..],
            &self.y_min[..],
            &self.y_max[..],
        ]
        .iter()
        .all(|s| s.iter().all(|v| bounded(*v)))
            && self.x_min.iter().zip(&self.x_max).all(gain_bounded)
    }

    /// Runs the net on the model inputs `x`, calling `emit(output, value)`
    /// for each of its outputs.
    pub fn evaluate(&self, x: &[f64], mut emit: impl FnMut(u8, f64)) {
        let m = self.inputs.len();
        // Each input is scaled once, not once per hidden neuron (a division
        // each: on the hub's M4F, f64 is software).
        let mut scaled = [0.0; MAX_CHANNELS];
        for (i, xs) in scaled.iter_mut().enumerate().take(m) {
            let ch = self.inputs.get(i).map_or(0, |c| usize::from(*c));
            let raw = x.get(ch).copied().unwrap_or(0.0);
            let lo = self.x_min.get(i).copied().unwrap_or(0.0);
            let hi = self.x_max.get(i).copied().unwrap_or(0.0);
            *xs = scale(raw, lo, hi);
        }
        let mut hidden = [0.0; MAX_HIDDEN];
        for (j, h) in hidden.iter_mut().enumerate().take(self.hidden()) {
            let row = self.w1.get(j * m..(j + 1) * m).unwrap_or(&[]);
            let acc = row
                .iter()
                .zip(&scaled)
                .fold(self.b1.get(j).copied().unwrap_or(0.0), |a, (w, xs)| {
                    a + w * xs
                });
            *h = self.hidden_activation.apply(acc);
        }
        let n = self.hidden();
        for (k, out) in self.outputs.iter().enumerate() {
            let row = self.w2.get(k * n..(k + 1) * n).unwrap_or(&[]);
            let acc = row
                .iter()
                .zip(&hidden)
                .fold(self.b2.get(k).copied().unwrap_or(0.0), |a, (w, h)| {
                    a + w * h
                });
            let o = self.output_activation.apply(acc);
            let lo = self.y_min.get(k).copied().unwrap_or(0.0);
            let hi = self.y_max.get(k).copied().unwrap_or(0.0);
            emit(*out, unscale(o, lo, hi));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn activations_match_matlab_definitions() {
        for n in [-30.0, -2.0, -0.1, 0.0, 0.7, 3.0, 800.0] {
            let tansig = 2.0 / (1.0 + libm::exp(-2.0 * n)) - 1.0;
            // tanh vs MATLAB's formula: equal to a few ulps.
            assert!((Activation::Tansig.apply(n) - tansig).abs() < 1e-15);
        }
        assert_eq!(Activation::Logsig.apply(0.0), 0.5);
        assert_eq!(Activation::Logsig.apply(-1e6), 0.0);
        assert_eq!(Activation::Tansig.apply(-1e6), -1.0);
    }

    #[test]
    fn mapminmax_round_trip_and_constant_rows() {
        assert_eq!(scale(20.0, 20.0, 30.0), -1.0);
        assert_eq!(scale(30.0, 20.0, 30.0), 1.0);
        assert_eq!(unscale(scale(23.7, 20.0, 30.0), 20.0, 30.0), 23.7);
        assert_eq!(scale(5.0, 5.0, 5.0), -1.0);
        assert_eq!(unscale(-1.0, 5.0, 5.0), 5.0);
    }

    #[test]
    fn two_by_two_by_one_by_hand() {
        // x in [0,10]^2 -> scaled; h = tanh(W1 xs + b1); y = W2 h + b2 -> [0,100].
        let net = BpNet {
            inputs: heapless::Vec::from_slice(&[0, 1]).unwrap(),
            outputs: heapless::Vec::from_slice(&[0]).unwrap(),
            hidden_activation: Activation::Tansig,
            output_activation: Activation::Purelin,
            w1: heapless::Vec::from_slice(&[0.5, -0.25, 1.0, 0.0]).unwrap(),
            b1: heapless::Vec::from_slice(&[0.1, -0.2]).unwrap(),
            w2: heapless::Vec::from_slice(&[0.8, -0.6]).unwrap(),
            b2: heapless::Vec::from_slice(&[0.05]).unwrap(),
            x_min: heapless::Vec::from_slice(&[0.0, 0.0]).unwrap(),
            x_max: heapless::Vec::from_slice(&[10.0, 10.0]).unwrap(),
            y_min: heapless::Vec::from_slice(&[0.0]).unwrap(),
            y_max: heapless::Vec::from_slice(&[100.0]).unwrap(),
        };
        assert!(net.shapes_agree());
        // x = (7.5, 2.5) -> xs = (0.5, -0.5); n1 = 0.25 + 0.125 + 0.1 = 0.475,
        // n2 = 0.5 - 0.2 = 0.3; o = 0.8 tanh(0.475) - 0.6 tanh(0.3) + 0.05;
        // y = (o + 1) * 50.
        let o = 0.8 * 0.475_f64.tanh() - 0.6 * 0.3_f64.tanh() + 0.05;
        let mut got = f64::NAN;
        net.evaluate(&[7.5, 2.5], |_, v| got = v);
        assert!((got - (o + 1.0) * 50.0).abs() < 1e-12, "{got}");
    }
}
