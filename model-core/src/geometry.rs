//! Five-point spindle geometry: from five eddy-current probe readings to the
//! spindle's thermal elongation and tilt, the tool-tip drift, and the
//! offsets a CNC must add to cancel it.
//!
//! # Probes and sign convention
//!
//! The five-point method (Yang, Zhang, Feng, Mei, Hu, *Thermal-induced errors
//! prediction and compensation for a coordinate boring machine based on time
//! series analysis*, Math. Probl. Eng. 2014, 784218: offset equations
//! (1)–(4), angle equations (25)–(28); Li et al., GA–BP thermal-error model
//! of a jig borer's high-speed spindle, the project's seed 000: compensation
//! equations (21)–(27)) places five probes around the spindle:
//!
//! | probe | measures | where |
//! |---|---|---|
//! | S1 | radial X | near the spindle nose |
//! | S3 | radial X | `a_mm` further up the spindle (120 mm in both papers) |
//! | S2 | radial Y | near the spindle nose |
//! | S4 | radial Y | `a_mm` further up the spindle |
//! | S5 | axial Z  | at the nose |
//!
//! Machine frame: Z+ points from the workpiece to the spindle, so the tool
//! points in −Z. All readings are in µm, and a *change* `dSᵢ = Sᵢ(t) − Sᵢ(0)`
//! is the displacement of the spindle surface at that probe in +X (S1, S3),
//! +Y (S2, S4), or, for S5, the axial elongation E, positive when the spindle
//! grows towards the workpiece. Probes that read gap rather than position
//! must have their sign flipped by the caller before they reach this module.
//!
//! # Elongation and tilt
//!
//! ```text
//! E  = dS5
//! θx = atan((dS1 − dS3) / a)     yaw: tilt in the XZ plane
//! θy = atan((dS2 − dS4) / a)     pitch: tilt in the YZ plane
//! ```
//!
//! The near probe moving more than the far one means the nose swings
//! towards +X (or +Y), which is a positive angle. A radial shift common to
//! both probes of a pair cancels in the difference: like the papers, the
//! model has no term for pure radial translation.
//!
//! # Tool-tip drift
//!
//! The spindle tilts about a deflection centre O at `l_defl_mm` above the
//! nose, and the tool sticks out `tool_mm` below it. With
//! `L = (l_defl_mm + tool_mm) · 1000` µm, the tip sits at `(0, 0, −L)` from O
//! before heating; after heating the axis has length `L + E` and direction
//! `d = (tan θx, tan θy, −1) / q` with `q = √(1 + tan²θx + tan²θy)`, so
//!
//! ```text
//! drift = (L + E) · d − (0, 0, −L)
//! dx = (L + E) tan θx / q ≈ (L + E) θx ≈ (l_defl + tool) θx
//! dy = (L + E) tan θy / q ≈ (l_defl + tool) θy
//! dz = L (1 − 1/q) − E/q  ≈ L θ²/2 − E ≈ −E
//! ```
//!
//! The approximations (E ≪ L, θ ≪ 1, and L θ²/2 of order 1e-3 µm for the
//! papers' angles) are the papers' compensation equations: the radial offsets
//! grow with the tool length, the axial one does not. This module evaluates
//! the exact expressions; `dz` is computed as `L·t²/(q(q+1)) − E/q` (with
//! `t² = tan²θx + tan²θy`), which equals `L − (L+E)/q` without subtracting two
//! nearly equal numbers of order L.
//!
//! The compensation offsets are the negated drift: what the CNC adds to the
//! commanded position so that the tip lands where it was programmed.

use core::f64::consts::FRAC_PI_2;
use core::fmt;

/// µm per mm, for the probe spacing and lengths given in mm.
const UM_PER_MM: f64 = 1000.0;

/// Why a geometry computation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum GeometryError {
    /// A probe reading, a change or a drift field was NaN or infinite, or
    /// two readings were so far apart that their difference overflowed.
    NonFiniteReading,
    /// The probe spacing was not finite and positive.
    InvalidSpacing,
    /// The deflection-centre distance or tool length was negative or not
    /// finite.
    InvalidLength,
    /// A tilt angle was at or beyond ±90°, where the axis direction is
    /// undefined; real thermal tilts are micro-radians.
    AngleOutOfRange,
    /// The result does not fit in an `f64`.
    Overflow,
}

impl fmt::Display for GeometryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::NonFiniteReading => "probe reading or drift is NaN or infinite",
            Self::InvalidSpacing => "probe spacing is not finite and positive",
            Self::InvalidLength => {
                "deflection-centre distance or tool length is negative or not finite"
            }
            Self::AngleOutOfRange => "tilt angle at or beyond +/-90 degrees",
            Self::Overflow => "tool-tip drift overflows f64",
        })
    }
}

impl core::error::Error for GeometryError {}

/// One sample of the five probes, or the change of each since a reference
/// sample, in µm.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProbeReadings {
    /// Radial X, near the nose.
    pub s1_um: f64,
    /// Radial Y, near the nose.
    pub s2_um: f64,
    /// Radial X, `a_mm` further up.
    pub s3_um: f64,
    /// Radial Y, `a_mm` further up.
    pub s4_um: f64,
    /// Axial, at the nose.
    pub s5_um: f64,
}

impl ProbeReadings {
    /// Changes `self − reference`, i.e. `Sᵢ(t) − Sᵢ(0)` when `reference` is
    /// the cold sample. Not checked here: [`spindle_drift`] checks the
    /// changes it is given.
    pub fn change_from(&self, reference: &Self) -> Self {
        Self {
            s1_um: self.s1_um - reference.s1_um,
            s2_um: self.s2_um - reference.s2_um,
            s3_um: self.s3_um - reference.s3_um,
            s4_um: self.s4_um - reference.s4_um,
            s5_um: self.s5_um - reference.s5_um,
        }
    }

    /// True when every reading is finite.
    fn is_finite(&self) -> bool {
        [self.s1_um, self.s2_um, self.s3_um, self.s4_um, self.s5_um]
            .iter()
            .all(|v| v.is_finite())
    }
}

/// The spindle's thermal pose change: axial elongation and two tilts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpindleDrift {
    /// Axial elongation E, µm; positive towards the workpiece (−Z).
    pub elongation_um: f64,
    /// Yaw θx: tilt in the XZ plane, rad; positive when the nose swings to +X.
    pub yaw_rad: f64,
    /// Pitch θy: tilt in the YZ plane, rad; positive when the nose swings to +Y.
    pub pitch_rad: f64,
}

/// Elongation and tilt from probe changes `dSᵢ` (µm) and the axial spacing
/// `a_mm` between the near and far radial probes.
pub fn spindle_drift(changes: &ProbeReadings, a_mm: f64) -> Result<SpindleDrift, GeometryError> {
    let a_um = a_mm * UM_PER_MM;
    if !a_um.is_finite() || a_um <= 0.0 {
        return Err(GeometryError::InvalidSpacing);
    }
    if !changes.is_finite() {
        return Err(GeometryError::NonFiniteReading);
    }
    let slope_x = (changes.s1_um - changes.s3_um) / a_um;
    let slope_y = (changes.s2_um - changes.s4_um) / a_um;
    // Finite inputs can still overflow in the difference (1e308 − (−1e308)).
    if !slope_x.is_finite() || !slope_y.is_finite() {
        return Err(GeometryError::NonFiniteReading);
    }
    Ok(SpindleDrift {
        elongation_um: changes.s5_um,
        yaw_rad: libm::atan(slope_x),
        pitch_rad: libm::atan(slope_y),
    })
}

impl SpindleDrift {
    /// Displacement of the tool tip caused by this drift, µm, for a
    /// deflection centre `l_defl_mm` above the nose and a tool sticking out
    /// `tool_mm` below it (exact geometry; see the module doc).
    pub fn tool_tip_drift(
        &self,
        l_defl_mm: f64,
        tool_mm: f64,
    ) -> Result<ToolTipDrift, GeometryError> {
        if !(l_defl_mm.is_finite() && tool_mm.is_finite() && l_defl_mm >= 0.0 && tool_mm >= 0.0) {
            return Err(GeometryError::InvalidLength);
        }
        // The fields are public, so a hand-built drift is re-checked here.
        if !(self.elongation_um.is_finite()
            && self.yaw_rad.is_finite()
            && self.pitch_rad.is_finite())
        {
            return Err(GeometryError::NonFiniteReading);
        }
        if libm::fabs(self.yaw_rad) >= FRAC_PI_2 || libm::fabs(self.pitch_rad) >= FRAC_PI_2 {
            return Err(GeometryError::AngleOutOfRange);
        }
        let tan_x = libm::tan(self.yaw_rad);
        let tan_y = libm::tan(self.pitch_rad);
        tip_from_tangents(self.elongation_um, tan_x, tan_y, l_defl_mm + tool_mm)
    }

    /// Offsets the CNC must add to cancel this drift, µm: the negated
    /// [`SpindleDrift::tool_tip_drift`].
    pub fn compensation_offsets(
        &self,
        l_defl_mm: f64,
        tool_mm: f64,
    ) -> Result<CompensationOffsets, GeometryError> {
        self.tool_tip_drift(l_defl_mm, tool_mm)
            .map(|drift| drift.compensation())
    }
}

/// The exact tip drift (module doc) for elongation `e_um`, the tangents of
/// the two tilts, and `l_mm = l_defl + tool`; the one formula both
/// [`SpindleDrift::tool_tip_drift`] and the hub's five-point path
/// (`crate::fivepoint`, which gets the tangents without `libm::tan`) use.
/// Lengths and finiteness of the inputs are the caller's to check.
pub(crate) fn tip_from_tangents(
    e_um: f64,
    tan_x: f64,
    tan_y: f64,
    l_mm: f64,
) -> Result<ToolTipDrift, GeometryError> {
    let l_um = l_mm * UM_PER_MM;
    if !l_um.is_finite() {
        return Err(GeometryError::InvalidLength);
    }
    let tan_sq = tan_x * tan_x + tan_y * tan_y;
    // q = 1/cos of the resultant tilt.
    let q = libm::sqrt(1.0 + tan_sq);
    let axis_um = l_um + e_um;
    let drift = ToolTipDrift {
        x_um: axis_um * tan_x / q,
        y_um: axis_um * tan_y / q,
        z_um: l_um * tan_sq / (q * (q + 1.0)) - e_um / q,
    };
    if drift.x_um.is_finite() && drift.y_um.is_finite() && drift.z_um.is_finite() {
        Ok(drift)
    } else {
        Err(GeometryError::Overflow)
    }
}

/// Where the tool tip moved, µm, in the machine frame (Z+ away from the
/// workpiece).
///
/// A separate type from [`CompensationOffsets`] so that a drift cannot be
/// sent to the CNC with the wrong sign by mistake.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ToolTipDrift {
    /// Drift along X, µm.
    pub x_um: f64,
    /// Drift along Y, µm.
    pub y_um: f64,
    /// Drift along Z, µm; negative when the tip moved towards the workpiece.
    pub z_um: f64,
}

impl ToolTipDrift {
    /// The offsets that cancel this drift.
    pub fn compensation(&self) -> CompensationOffsets {
        CompensationOffsets {
            x_um: -self.x_um,
            y_um: -self.y_um,
            z_um: -self.z_um,
        }
    }
}

/// Offsets to add to the commanded tool position, µm, in the machine frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CompensationOffsets {
    /// Offset along X, µm.
    pub x_um: f64,
    /// Offset along Y, µm.
    pub y_um: f64,
    /// Offset along Z, µm.
    pub z_um: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn readings(s1: f64, s2: f64, s3: f64, s4: f64, s5: f64) -> ProbeReadings {
        ProbeReadings {
            s1_um: s1,
            s2_um: s2,
            s3_um: s3,
            s4_um: s4,
            s5_um: s5,
        }
    }

    #[test]
    fn change_from_subtracts_the_reference() {
        let cold = readings(100.0, 200.0, 300.0, 400.0, 500.0);
        let warm = readings(112.0, 195.0, 300.0, 401.0, 520.0);
        assert_eq!(
            warm.change_from(&cold),
            readings(12.0, -5.0, 0.0, 1.0, 20.0)
        );
    }

    #[test]
    fn signs_of_the_angles() {
        // Near probe moving +X more than the far one: nose swings +X, θx > 0;
        // the far probe moving more: θx < 0. Same in Y.
        let d = spindle_drift(&readings(5.0, -5.0, 0.0, 0.0, 0.0), 120.0);
        let d = d.unwrap_or(SpindleDrift {
            elongation_um: 0.0,
            yaw_rad: 0.0,
            pitch_rad: 0.0,
        });
        assert!(d.yaw_rad > 0.0 && d.pitch_rad < 0.0, "{d:?}");
    }

    #[test]
    fn common_mode_radial_shift_gives_no_tilt() {
        // Both X probes read +7 µm: a translation, not a tilt; exact zero.
        let d = spindle_drift(&readings(7.0, 0.0, 7.0, 0.0, 0.0), 120.0);
        assert_eq!(d.map(|d| d.yaw_rad), Ok(0.0));
    }

    #[test]
    fn rejects_bad_inputs() {
        let zero = ProbeReadings::default();
        assert_eq!(
            spindle_drift(&zero, 0.0),
            Err(GeometryError::InvalidSpacing)
        );
        assert_eq!(
            spindle_drift(&zero, -1.0),
            Err(GeometryError::InvalidSpacing)
        );
        assert_eq!(
            spindle_drift(&zero, f64::NAN),
            Err(GeometryError::InvalidSpacing)
        );
        assert_eq!(
            spindle_drift(&zero, f64::MAX),
            Err(GeometryError::InvalidSpacing)
        );
        let nan = readings(0.0, 0.0, 0.0, 0.0, f64::NAN);
        assert_eq!(
            spindle_drift(&nan, 120.0),
            Err(GeometryError::NonFiniteReading)
        );
        let huge = readings(f64::MAX, 0.0, -f64::MAX, 0.0, 0.0);
        assert_eq!(
            spindle_drift(&huge, 1e-3),
            Err(GeometryError::NonFiniteReading)
        );

        let ok = SpindleDrift {
            elongation_um: 1.0,
            yaw_rad: 0.0,
            pitch_rad: 0.0,
        };
        assert_eq!(
            ok.tool_tip_drift(-1.0, 100.0),
            Err(GeometryError::InvalidLength)
        );
        assert_eq!(
            ok.tool_tip_drift(300.0, f64::INFINITY),
            Err(GeometryError::InvalidLength)
        );
        let steep = SpindleDrift {
            yaw_rad: FRAC_PI_2,
            ..ok
        };
        assert_eq!(
            steep.tool_tip_drift(300.0, 100.0),
            Err(GeometryError::AngleOutOfRange)
        );
        let nan = SpindleDrift {
            pitch_rad: f64::NAN,
            ..ok
        };
        assert_eq!(
            nan.tool_tip_drift(300.0, 100.0),
            Err(GeometryError::NonFiniteReading)
        );
        assert_eq!(
            ok.tool_tip_drift(f64::MAX, f64::MAX),
            Err(GeometryError::InvalidLength)
        );
    }

    #[test]
    fn stable_z_matches_the_direct_formula() {
        // At a large tilt (0.3 rad) cancellation is harmless, so the direct
        // L − (L+E)·cos θ is a fair reference; 1e-9 µm is ~1e-15 of L.
        let d = SpindleDrift {
            elongation_um: 15.0,
            yaw_rad: 0.3,
            pitch_rad: 0.0,
        };
        let tip = d.tool_tip_drift(250.0, 50.0).unwrap_or_default();
        let l_um = 300_000.0;
        let direct = l_um - (l_um + 15.0) * libm::cos(0.3);
        assert!((tip.z_um - direct).abs() < 1e-9, "{} vs {direct}", tip.z_um);
    }

    #[test]
    fn offsets_are_the_negated_drift() {
        let d = SpindleDrift {
            elongation_um: 3.0,
            yaw_rad: 2e-5,
            pitch_rad: -1e-5,
        };
        let tip = d.tool_tip_drift(300.0, 80.0).unwrap_or_default();
        let off = d.compensation_offsets(300.0, 80.0).unwrap_or_default();
        assert_eq!(
            (off.x_um, off.y_um, off.z_um),
            (-tip.x_um, -tip.y_um, -tip.z_um)
        );
        assert!(
            tip.x_um > 0.0 && tip.y_um < 0.0 && tip.z_um < 0.0,
            "{tip:?}"
        );
    }

    #[test]
    fn display_names_the_problem() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(
            GeometryError::InvalidSpacing.to_string(),
            "probe spacing is not finite and positive"
        );
    }
}
