//! Position-dependent positioning error of a feed axis (seed 003, Eq. 1-3, 16).
//!
//! A feed axis' positioning error at nominal position `P` is a geometric part
//! measured cold, a polynomial `poly(P)`, plus a thermal part that grows
//! linearly along the stroke, `(k(T) - k0) P`, where `k(T)` is the slope a
//! temperature model predicts and `k0` the slope of the cold curve. Seed 003's
//! Eq. 16 is exactly this with a fifth-order `poly` and `k(T)` from PCR.

use serde::{Deserialize, Serialize};

/// Coefficients of the geometric polynomial (order up to 7).
pub const MAX_POLY_COEFFS: usize = 8;

/// `poly(P) + (k - k0) P`, with `P` read from a model input channel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PositionTerm {
    /// Input channel holding the axis position `P` (e.g. `y_mm`).
    pub channel: u8,
    /// Geometric error polynomial `c0 + c1 P + c2 P^2 + ...`.
    pub poly: heapless::Vec<f64, MAX_POLY_COEFFS>,
    /// Slope of the cold (initial) positioning error curve.
    pub k0: f64,
}

impl PositionTerm {
    /// The positioning error at position `p` for the predicted slope `k`.
    pub fn error(&self, k: f64, p: f64) -> f64 {
        // Horner, highest power first.
        let geometric = self.poly.iter().rev().fold(0.0, |acc, c| acc * p + c);
        geometric + (k - self.k0) * p
    }

    /// All coefficients are finite.
    pub fn is_finite(&self) -> bool {
        self.k0.is_finite() && self.poly.iter().all(|c| c.is_finite())
    }
}
