//! Five-point models: a model whose outputs are the spindle's elongation and
//! two tilts, turned into tool-tip offsets with the current tool length.
//!
//! Seeds 000 and 001 do not model the tool-tip drift itself: they model the
//! axial elongation `E` and the yaw and pitch angles `θx`, `θy` measured by
//! the five-point probes (seed 001 Eq. 25–28), and compensate at the tip
//! with the geometry (seed 001 Eq. 1–4 and 36; seed 000 Eq. 21–27):
//!
//! ```text
//! dx ≈ (l_defl + tool) θx      dy ≈ (l_defl + tool) θy      dz ≈ −E
//! ```
//!
//! so a tool change moves the radial offsets at once, without a new model.
//! A model with exactly the outputs [`E_OUTPUT`], [`THETA_X_OUTPUT`] and
//! [`THETA_Y_OUTPUT`] (any order) may carry a [`FivePoint`]: the distance
//! `l_defl_mm` from the spindle nose up to the deflection centre, the one
//! length the tip geometry needs besides the tool's. [`TipMap::tool_tip`]
//! evaluates the exact geometry of [`crate::geometry`] (the approximations
//! above hold to ~1e-3 µm at thermal angles).
//!
//! Units: `e_um` in µm, positive when the spindle grows towards the
//! workpiece; `theta_*_urad` in µrad, positive when the nose swings to +X
//! (+Y); the tip drift in µm in the machine frame (Z+ away from the
//! workpiece), the same sign as a run file's `dx_um`, `dy_um`, `dz_um`.

use crate::capacity::Name;
use crate::error::ModelError;
use crate::geometry::{tip_from_tangents, GeometryError, SpindleDrift, ToolTipDrift};
use serde::{Deserialize, Serialize};

/// Output name of the axial elongation E, µm.
pub const E_OUTPUT: &str = "e_um";
/// Output name of the yaw θx (tilt in the XZ plane), µrad.
pub const THETA_X_OUTPUT: &str = "theta_x_urad";
/// Output name of the pitch θy (tilt in the YZ plane), µrad.
pub const THETA_Y_OUTPUT: &str = "theta_y_urad";
/// The tool-tip drift columns a five-point model's outputs become, in the
/// order the hub reports them (X, Y, Z).
pub const TIP_OUTPUTS: [&str; 3] = ["dx_um", "dy_um", "dz_um"];
/// Default deflection-centre distance, mm: the twin's default machine
/// (seed 000, Fig. 1: radial pairs 120 mm apart, centre 300 mm above the
/// nose). A user measures their own spindle's.
pub const DEFAULT_L_DEFL_MM: f64 = 300.0;
pub use crate::capacity::MAX_L_DEFL_MM;
/// µrad per rad.
const URAD_PER_RAD: f64 = 1e6;
/// Largest tilt [`TipMap::tool_tip`] accepts, rad: 10 mrad (10 mm per metre),
/// a thousand times the tilts the seeds measure (tens of µrad). Within it
/// the tangent's series to θ⁹ is exact in f64 (the next term is below
/// 1e-19 relative), which spares the hub `libm::tan` (~4.7 KiB of flash).
pub const MAX_TILT_RAD: f64 = 0.01;

/// tan θ for |θ| <= [`MAX_TILT_RAD`]: θ + θ³/3 + 2θ⁵/15 + 17θ⁷/315 + 62θ⁹/2835.
fn tan_small(theta: f64) -> f64 {
    let t2 = theta * theta;
    theta
        * (1.0 + t2 * (1.0 / 3.0 + t2 * (2.0 / 15.0 + t2 * (17.0 / 315.0 + t2 * (62.0 / 2835.0)))))
}

/// The geometry a five-point model carries in its blob (format 3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FivePoint {
    /// Distance from the spindle nose up to the deflection centre O, mm.
    pub l_defl_mm: f64,
}

/// Whether `outputs` are exactly the five-point outputs, in any order.
pub fn is_five_point(outputs: &[Name]) -> bool {
    outputs.len() == 3
        && [E_OUTPUT, THETA_X_OUTPUT, THETA_Y_OUTPUT]
            .iter()
            .all(|want| outputs.iter().any(|o| o.as_str() == *want))
}

/// A checked [`FivePoint`]: which model output is which, and `l_defl_mm`.
/// Built by `Model::validate`; using it cannot fail on its own account.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TipMap {
    e: usize,
    theta_x: usize,
    theta_y: usize,
    l_defl_mm: f64,
}

impl FivePoint {
    /// Checks the geometry against the model's outputs.
    pub(crate) fn map(&self, outputs: &[Name]) -> Result<TipMap, ModelError> {
        let at = |want: &str| outputs.iter().position(|o| o.as_str() == want);
        let in_range =
            self.l_defl_mm.is_finite() && (0.0..=MAX_L_DEFL_MM).contains(&self.l_defl_mm);
        match (is_five_point(outputs), in_range) {
            (true, true) => Ok(TipMap {
                e: at(E_OUTPUT).unwrap_or(0),
                theta_x: at(THETA_X_OUTPUT).unwrap_or(0),
                theta_y: at(THETA_Y_OUTPUT).unwrap_or(0),
                l_defl_mm: self.l_defl_mm,
            }),
            _ => Err(ModelError::BadFivePoint),
        }
    }
}

impl TipMap {
    /// Distance from the nose up to the deflection centre, mm.
    pub fn l_defl_mm(&self) -> f64 {
        self.l_defl_mm
    }

    /// The model output each tip axis (X, Y, Z) comes from: θx, θy, E.
    pub fn source_outputs(&self) -> [usize; 3] {
        [self.theta_x, self.theta_y, self.e]
    }

    /// The spindle drift the model outputs `values` (in output order) say.
    pub fn drift(&self, values: &[f64]) -> SpindleDrift {
        let v = |k: usize| values.get(k).copied().unwrap_or(f64::NAN);
        SpindleDrift {
            elongation_um: v(self.e),
            yaw_rad: v(self.theta_x) / URAD_PER_RAD,
            pitch_rad: v(self.theta_y) / URAD_PER_RAD,
        }
    }

    /// Tool-tip drift `[dx, dy, dz]`, µm, for model outputs `values` and a
    /// tool sticking out `tool_mm` below the nose (exact geometry, seed 001
    /// Eq. 1–4; the same formula as [`SpindleDrift::tool_tip_drift`]).
    /// Fails only on non-finite outputs, a negative or non-finite tool
    /// length, or a tilt beyond [`MAX_TILT_RAD`] (`AngleOutOfRange`).
    pub fn tool_tip(&self, values: &[f64], tool_mm: f64) -> Result<[f64; 3], GeometryError> {
        let d = self.drift(values);
        if !(d.elongation_um.is_finite() && d.yaw_rad.is_finite() && d.pitch_rad.is_finite()) {
            return Err(GeometryError::NonFiniteReading);
        }
        if libm::fabs(d.yaw_rad) > MAX_TILT_RAD || libm::fabs(d.pitch_rad) > MAX_TILT_RAD {
            return Err(GeometryError::AngleOutOfRange);
        }
        if !(tool_mm.is_finite() && tool_mm >= 0.0) {
            return Err(GeometryError::InvalidLength);
        }
        let (tan_x, tan_y) = (tan_small(d.yaw_rad), tan_small(d.pitch_rad));
        let ToolTipDrift { x_um, y_um, z_um } =
            tip_from_tangents(d.elongation_um, tan_x, tan_y, self.l_defl_mm + tool_mm)?;
        Ok([x_um, y_um, z_um])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: &[&str]) -> heapless::Vec<Name, 4> {
        n.iter().filter_map(|s| Name::try_from(*s).ok()).collect()
    }

    #[test]
    fn maps_outputs_in_any_order() {
        let out = names(&["theta_y_urad", "e_um", "theta_x_urad"]);
        let map = FivePoint { l_defl_mm: 300.0 }.map(&out);
        assert_eq!(map.map(|m| m.source_outputs()), Ok([2, 0, 1]));
    }

    #[test]
    fn refuses_other_outputs_and_bad_lengths() {
        let fp = FivePoint { l_defl_mm: 300.0 };
        for bad in [
            names(&["e_um", "theta_x_urad"]),
            names(&["e_um", "theta_x_urad", "dz_um"]),
            names(&["e_um", "theta_x_urad", "theta_y_urad", "dz_um"]),
        ] {
            assert_eq!(fp.map(&bad), Err(ModelError::BadFivePoint), "{bad:?}");
        }
        let ok = names(&["e_um", "theta_x_urad", "theta_y_urad"]);
        for l in [-1.0, f64::NAN, f64::INFINITY, MAX_L_DEFL_MM + 1.0] {
            let fp = FivePoint { l_defl_mm: l };
            assert_eq!(fp.map(&ok), Err(ModelError::BadFivePoint), "{l}");
        }
    }

    #[test]
    fn small_tangent_agrees_with_libm_and_the_geometry() {
        // Two implementations agree: the series against libm::tan within
        // 2 ulp over the accepted range, and the tip against
        // SpindleDrift::tool_tip_drift within 1e-12 relative.
        for k in -100..=100 {
            let theta = MAX_TILT_RAD * f64::from(k) / 100.0;
            let (a, b) = (tan_small(theta), libm::tan(theta));
            assert!(
                (a - b).abs() <= 2.0 * f64::EPSILON * b.abs(),
                "{theta}: {a} vs {b}"
            );
        }
        let out = names(&["e_um", "theta_x_urad", "theta_y_urad"]);
        let map = FivePoint { l_defl_mm: 250.0 }.map(&out);
        let values = [31.5, 8000.0, -2500.0];
        let tip = map.map(|m| m.tool_tip(&values, 120.0));
        let want = map.map(|m| m.drift(&values).tool_tip_drift(250.0, 120.0));
        match (tip, want) {
            (Ok(Ok(t)), Ok(Ok(w))) => {
                for (a, b) in t.iter().zip([w.x_um, w.y_um, w.z_um]) {
                    assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} vs {b}");
                }
            }
            other => panic!("{other:?}"),
        }
        // Beyond 10 mrad: refused, not extrapolated.
        let far = map.map(|m| m.tool_tip(&[0.0, 10_001.0, 0.0], 100.0));
        assert_eq!(far, Ok(Err(GeometryError::AngleOutOfRange)));
    }

    #[test]
    fn tip_is_l_times_theta_and_minus_e() {
        // θx = 100 µrad, θy = −50 µrad, E = 20 µm; L = 300 + 100 mm.
        // dx = (L + E) tan θx / q: 400 020 µm · 1e-4 · (1 − ~6e-9) =
        // 40.002 µm within 1e-6; dz = −E/q + L·t²/(q(q+1)) = −20 + 2.5e-3.
        let out = names(&["e_um", "theta_x_urad", "theta_y_urad"]);
        let map = FivePoint { l_defl_mm: 300.0 }.map(&out);
        let tip = map.and_then(|m| {
            m.tool_tip(&[20.0, 100.0, -50.0], 100.0)
                .map_err(|_| ModelError::NonFinite)
        });
        let [dx, dy, dz] = tip.unwrap_or([f64::NAN; 3]);
        assert!((dx - 40.002).abs() < 1e-6, "{dx}");
        assert!((dy + 20.001).abs() < 1e-6, "{dy}");
        assert!(
            (dz - (-20.0 + 400_000.0 * 1.25e-8 / 2.0)).abs() < 1e-6,
            "{dz}"
        );
    }
}
