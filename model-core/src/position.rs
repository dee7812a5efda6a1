//! Position-dependent positioning error of a feed axis (seed 003, Eq. 1-3, 16).
//!
//! A feed axis' positioning error at nominal position `P` is a geometric part
//! measured cold, a polynomial `poly(P)`, plus a thermal part that grows
//! linearly along the stroke, `(k(T) - k0) P`, where `k(T)` is the slope a
//! temperature model predicts and `k0` the slope of the cold curve. Seed 003's
//! Eq. 16 is exactly this with a fifth-order `poly` and `k(T)` from PCR.
//!
//! Units: `P` in mm (the position input's unit), the error in um, so the
//! slopes are um per mm of travel.
//!
//! On the machine, the two parts go to different places. The geometric
//! part is the CNC's own pitch-error (leadscrew) compensation. The thermal
//! part is what a CNC's position-dependent temperature compensation takes
//! as an offset plus a slope about a reference position (Siemens
//! TEMP_COMP: `K0 + tan(beta) (P - P0)`): here `P0 = 0`, where the thermal
//! part vanishes, so `K0 = 0` and the slope is `k(T) - k0`
//! ([`PositionTerm::thermal_slope`]). The hub sends that slope, not a
//! value at one position: it does not know where the axis is.

use serde::{Deserialize, Serialize};

/// Coefficients of the geometric polynomial (order up to 7).
pub const MAX_POLY_COEFFS: usize = 8;

/// `poly(P) + (k - k0) P`, with `P` read from a model input channel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PositionTerm {
    /// Input channel holding the axis position `P` (e.g. `y_mm`).
    pub channel: u8,
    /// Geometric error polynomial `c0 + c1 P + c2 P^2 + ...`.
    #[serde(deserialize_with = "crate::wire::list")]
    pub poly: heapless::Vec<f64, MAX_POLY_COEFFS>,
    /// Slope of the cold (initial) positioning error curve.
    pub k0: f64,
}

impl PositionTerm {
    /// The positioning error at position `p` for the predicted slope `k`.
    pub fn error(&self, k: f64, p: f64) -> f64 {
        // Horner, highest power first.
        let geometric = self.poly.iter().rev().fold(0.0, |acc, c| acc * p + c);
        geometric + self.thermal_slope(k) * p
    }

    /// The thermal error's growth per mm of travel for the predicted slope
    /// `k`: `k - k0`, um/mm (its value at `P0 = 0` is zero).
    pub fn thermal_slope(&self, k: f64) -> f64 {
        k - self.k0
    }

    /// All coefficients are finite and within
    /// [`crate::capacity::MAX_MAGNITUDE`].
    pub fn is_bounded(&self) -> bool {
        use crate::capacity::bounded;
        bounded(self.k0) && self.poly.iter().all(|c| bounded(*c))
    }
}
