//! Platinum RTD conversion (PT100, PT1000 or any R0) between resistance and
//! temperature, a ratiometric converter model, and open/short detection.
//!
//! # Method
//!
//! The resistance of an industrial platinum RTD follows the Callendar–Van
//! Dusen (CVD) equation with the coefficients fixed by IEC 60751:2008,
//! *Industrial platinum resistance thermometers and platinum temperature
//! sensors* (H. L. Callendar, Phil. Trans. R. Soc. A 178, 1887; M. S. Van
//! Dusen, J. Am. Chem. Soc. 47, 326, 1925):
//!
//! ```text
//! R(T) = R0 (1 + A T + B T²)                      0 °C ≤ T ≤ 850 °C
//! R(T) = R0 (1 + A T + B T² + C (T − 100) T³)  −200 °C ≤ T < 0 °C
//! A = 3.9083e-3 /°C,  B = −5.775e-7 /°C²,  C = −4.183e-12 /°C⁴
//! ```
//!
//! The inverse has two branches:
//!
//! * `R ≥ R0`: the equation is a quadratic in T, solved in closed form. The
//!   physical root is written as `T = 2x / (A + √(A² + 4Bx))` with
//!   `x = R/R0 − 1`, the cancellation-free form of the quadratic formula
//!   (D. Goldberg, *What every computer scientist should know about
//!   floating-point arithmetic*, ACM Comput. Surv. 23(1), 1991; Press et al.,
//!   *Numerical Recipes*, 3rd ed., §5.6). The textbook form `(−A + √…)/(2B)`
//!   cancels near 0 °C: its absolute error stays near ε·A/|B| ≈ 4e-13 °C,
//!   but a temperature of a few µ°C keeps only a few significant digits.
//! * `R < R0`: the quartic C term makes a closed form impractical, so Newton's
//!   method runs from the quadratic root (which is within about 2.3 °C of
//!   the answer at −200 °C, where the C term is largest). Below 0 °C the
//!   slope dR/dT never drops under A·R0, so Newton converges quadratically
//!   in a few steps; the loop is bounded anyway so no input can stall it.
//!
//! Round trip T → R → T is accurate to about 1e-13 °C over the whole range
//! (checked on a 0.1 °C grid by the golden tests).
//!
//! # Converter
//!
//! [`Ratiometric`] models a converter that measures the RTD against a
//! reference resistor, so `R = code / full_scale_code · R_ref`. The MAX31865
//! (Maxim datasheet 19-6478, Tables 4–5) returns a 15-bit code (the RTD
//! register shifted right by one to drop the fault bit) with `full_scale_code
//! = 2¹⁵`; its worked example (Table 9) pairs a PT100 with `R_ref` = 400 Ω,
//! i.e. 4·R0, so a PT1000 takes 4 kΩ.
//!
//! # Faults
//!
//! [`Rtd::classify`] sorts a measured resistance into a temperature or an
//! [`RtdError::Open`], [`RtdError::Short`] or
//! [`RtdError::ResistanceOutOfRange`] using the limits in [`FaultThresholds`].

use core::fmt;

/// CVD coefficient A of IEC 60751, in 1/°C.
pub const CVD_A: f64 = 3.9083e-3;
/// CVD coefficient B of IEC 60751, in 1/°C².
pub const CVD_B: f64 = -5.775e-7;
/// CVD coefficient C of IEC 60751, in 1/°C⁴; it applies below 0 °C only.
pub const CVD_C: f64 = -4.183e-12;
/// Lowest temperature IEC 60751 defines the curve for, in °C.
pub const T_MIN_C: f64 = -200.0;
/// Highest temperature IEC 60751 defines the curve for, in °C.
pub const T_MAX_C: f64 = 850.0;

const _: () = assert!(T_MIN_C < T_MAX_C);

/// R/R0 at [`T_MIN_C`].
const RATIO_MIN: f64 = cvd_ratio(T_MIN_C);
/// R/R0 at [`T_MAX_C`].
const RATIO_MAX: f64 = cvd_ratio(T_MAX_C);
/// Newton stops once a step is smaller than this, in °C.
const NEWTON_TOL_C: f64 = 1e-9;
/// Newton needs 3–4 steps from the quadratic start; this only bounds the loop.
const NEWTON_MAX_STEPS: u32 = 16;

/// Why an RTD conversion or classification failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum RtdError {
    /// An input was NaN or infinite.
    NonFinite,
    /// A temperature outside −200..=850 °C, where IEC 60751 defines no curve.
    TemperatureOutOfRange,
    /// A resistance outside R(−200 °C)..=R(850 °C) that is still plausible
    /// for a connected sensor (neither [`RtdError::Open`] nor
    /// [`RtdError::Short`]).
    ResistanceOutOfRange,
    /// The reading says the sensor or a lead is open (broken).
    Open,
    /// The reading says the sensor or its leads are shorted.
    Short,
    /// A raw code at or above the converter's full-scale code.
    CodeOutOfRange,
    /// A configuration value (R0, R_ref, full-scale code, threshold) is not
    /// finite and positive, or an R0 is too extreme to keep precision.
    InvalidParameter,
}

impl fmt::Display for RtdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::NonFinite => "input is NaN or infinite",
            Self::TemperatureOutOfRange => "temperature outside -200..=850 C",
            Self::ResistanceOutOfRange => "resistance outside the RTD's -200..=850 C range",
            Self::Open => "RTD open circuit",
            Self::Short => "RTD short circuit",
            Self::CodeOutOfRange => "converter code at or above full scale",
            Self::InvalidParameter => "RTD, converter or threshold parameter out of range",
        })
    }
}

impl core::error::Error for RtdError {}

/// R(T)/R0 by the CVD equation, without a range check.
const fn cvd_ratio(t_c: f64) -> f64 {
    let quadratic = 1.0 + t_c * (CVD_A + CVD_B * t_c);
    if t_c < 0.0 {
        quadratic + CVD_C * (t_c - 100.0) * t_c * t_c * t_c
    } else {
        quadratic
    }
}

/// d(R/R0)/dT, in 1/°C; at least A below 0 °C, where Newton uses it.
fn cvd_slope(t_c: f64) -> f64 {
    let quadratic = CVD_A + 2.0 * CVD_B * t_c;
    if t_c < 0.0 {
        quadratic + CVD_C * t_c * t_c * (4.0 * t_c - 300.0)
    } else {
        quadratic
    }
}

/// Root of `1 + A T + B T² = ratio` that passes through 0 °C, in the
/// cancellation-free form (see the module doc). The discriminant stays above
/// 8.5e-6 for any ratio up to R(850 °C)/R0, so the square root is real.
fn quadratic_root_c(ratio: f64) -> f64 {
    let x = ratio - 1.0;
    let discriminant = CVD_A * CVD_A + 4.0 * CVD_B * x;
    2.0 * x / (CVD_A + libm::sqrt(discriminant))
}

/// Solves the full CVD equation below 0 °C by Newton's method from `start_c`.
fn newton_root_c(ratio: f64, start_c: f64) -> f64 {
    let mut t_c = start_c;
    for _ in 0..NEWTON_MAX_STEPS {
        let step_c = (cvd_ratio(t_c) - ratio) / cvd_slope(t_c);
        t_c -= step_c;
        if libm::fabs(step_c) < NEWTON_TOL_C {
            break;
        }
    }
    t_c
}

/// A platinum RTD element with the IEC 60751 curve and a nominal resistance
/// R0 at 0 °C.
///
/// R0 is private so that every `Rtd` has a finite, positive R0 and the
/// conversions need not re-check it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rtd {
    r0_ohm: f64,
}

impl Rtd {
    /// PT100: R0 = 100 Ω.
    pub const PT100: Self = Self { r0_ohm: 100.0 };
    /// PT1000: R0 = 1000 Ω.
    pub const PT1000: Self = Self { r0_ohm: 1000.0 };

    /// An element with a custom R0 (e.g. PT500).
    ///
    /// Rejects an R0 that is not finite and positive, or so extreme that
    /// R(−200 °C) is subnormal or R(850 °C) overflows, where the curve
    /// would lose its precision.
    pub const fn new(r0_ohm: f64) -> Result<Self, RtdError> {
        if !r0_ohm.is_finite() {
            return Err(RtdError::NonFinite);
        }
        if r0_ohm <= 0.0 || !(r0_ohm * RATIO_MIN).is_normal() || !(r0_ohm * RATIO_MAX).is_finite() {
            return Err(RtdError::InvalidParameter);
        }
        Ok(Self { r0_ohm })
    }

    /// Nominal resistance at 0 °C, in Ω.
    pub const fn r0_ohm(&self) -> f64 {
        self.r0_ohm
    }

    /// Resistance at −200 °C, the lowest the curve is defined for, in Ω.
    pub const fn r_min_ohm(&self) -> f64 {
        self.r0_ohm * RATIO_MIN
    }

    /// Resistance at 850 °C, the highest the curve is defined for, in Ω.
    pub const fn r_max_ohm(&self) -> f64 {
        self.r0_ohm * RATIO_MAX
    }

    /// Resistance at `t_c` by the CVD equation, in Ω.
    pub fn resistance_ohm(&self, t_c: f64) -> Result<f64, RtdError> {
        if !t_c.is_finite() {
            return Err(RtdError::NonFinite);
        }
        if !(T_MIN_C..=T_MAX_C).contains(&t_c) {
            return Err(RtdError::TemperatureOutOfRange);
        }
        Ok(self.r0_ohm * cvd_ratio(t_c))
    }

    /// Temperature for a resistance `r_ohm`, in °C, by the inverse CVD
    /// equation (closed form at or above R0, Newton below).
    ///
    /// Resistances outside R(−200 °C)..=R(850 °C) are an error; use
    /// [`Rtd::classify`] to tell a broken sensor from an out-of-range one.
    pub fn temperature_c(&self, r_ohm: f64) -> Result<f64, RtdError> {
        if !r_ohm.is_finite() {
            return Err(RtdError::NonFinite);
        }
        // Compared in ohms, with the same products as `resistance_ohm`, so
        // that R(−200 °C) and R(850 °C) themselves are accepted exactly.
        if r_ohm < self.r_min_ohm() || r_ohm > self.r_max_ohm() {
            return Err(RtdError::ResistanceOutOfRange);
        }
        let ratio = r_ohm / self.r0_ohm;
        let quadratic_c = quadratic_root_c(ratio);
        let t_c = if ratio >= 1.0 {
            quadratic_c
        } else {
            newton_root_c(ratio, quadratic_c)
        };
        // The division above may round a boundary resistance a hair past the
        // range; the curve is monotonic, so clamping is exact, not a fudge.
        // `clamp` cannot panic: its bounds are ordered constants (asserted
        // at compile time below).
        Ok(t_c.clamp(T_MIN_C, T_MAX_C))
    }

    /// Classifies a measured resistance: the temperature if the reading is
    /// in range, else which fault it shows.
    ///
    /// Checks run in this order: [`RtdError::NonFinite`],
    /// [`RtdError::InvalidParameter`] (thresholds or converter),
    /// [`RtdError::Open`], [`RtdError::Short`],
    /// [`RtdError::ResistanceOutOfRange`]. Pass the converter as `adc` so that
    /// a reading at its full scale (the usual symptom of an open input) is
    /// caught even when full scale is close to R(850 °C).
    pub fn classify(
        &self,
        r_ohm: f64,
        adc: Option<&Ratiometric>,
        thresholds: &FaultThresholds,
    ) -> Result<f64, RtdError> {
        if !r_ohm.is_finite() {
            return Err(RtdError::NonFinite);
        }
        thresholds.validate()?;
        let mut open_ohm = thresholds.open_factor_of_r_max * self.r_max_ohm();
        if let Some(adc) = adc {
            adc.validate()?;
            open_ohm = open_ohm.min(thresholds.open_fraction_of_full_scale * adc.r_ref_ohm);
        }
        if r_ohm >= open_ohm {
            return Err(RtdError::Open);
        }
        if r_ohm < thresholds.short_factor_of_r_min * self.r_min_ohm() {
            return Err(RtdError::Short);
        }
        self.temperature_c(r_ohm)
    }
}

/// Limits that separate a broken sensor from an out-of-range reading.
///
/// All are factors, so one set serves PT100 and PT1000 alike.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultThresholds {
    /// A reading at or above this fraction of the converter's full scale
    /// (`R_ref`) is [`RtdError::Open`]. Default 0.99: with the MAX31865's
    /// 4·R0 reference (400 Ω / 4 kΩ), R(850 °C) sits at 0.976 of full
    /// scale, so no valid reading is flagged, while an open input, which
    /// pulls the input to the bias voltage and the converter to its top code
    /// (0.99997 of full scale), is.
    pub open_fraction_of_full_scale: f64,
    /// A reading at or above this multiple of R(850 °C) is
    /// [`RtdError::Open`], for converters whose full scale is far above the
    /// RTD's range. Default 2.0: a healthy element never exceeds R(850 °C);
    /// doubling it leaves room for lead resistance (a few Ω) and converter
    /// gain error (well under 1 %) while still catching a broken lead. This
    /// is an engineering margin, not a value from a standard.
    pub open_factor_of_r_max: f64,
    /// A reading below this multiple of R(−200 °C) is [`RtdError::Short`].
    /// Default 0.5 (9.26 Ω for a PT100): no element goes below R(−200 °C),
    /// so half of it can only be a short across the element or its leads,
    /// whose residual resistance is a few ohms at most. Also an engineering
    /// margin, not a value from a standard.
    pub short_factor_of_r_min: f64,
}

impl FaultThresholds {
    /// The documented defaults, usable in `const` context.
    pub const DEFAULT: Self = Self {
        open_fraction_of_full_scale: 0.99,
        open_factor_of_r_max: 2.0,
        short_factor_of_r_min: 0.5,
    };

    /// Every threshold must be finite and positive.
    fn validate(&self) -> Result<(), RtdError> {
        let all_ok = [
            self.open_fraction_of_full_scale,
            self.open_factor_of_r_max,
            self.short_factor_of_r_min,
        ]
        .iter()
        .all(|v| v.is_finite() && *v > 0.0);
        if all_ok {
            Ok(())
        } else {
            Err(RtdError::InvalidParameter)
        }
    }
}

impl Default for FaultThresholds {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A raw code from a ratiometric RTD converter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct RtdCode(pub u32);

/// A converter that measures the RTD against a reference resistor:
/// `R = code / full_scale_code · r_ref_ohm`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ratiometric {
    /// The code that would mean R = R_ref: 2ᴺ for an N-bit converter, whose
    /// largest output is `full_scale_code − 1`. Must be positive.
    pub full_scale_code: u32,
    /// Reference resistor, in Ω. Must be finite and positive.
    pub r_ref_ohm: f64,
}

impl Ratiometric {
    /// MAX31865 with the 400 Ω (4·R0) reference of its datasheet's PT100
    /// example.
    pub const MAX31865_PT100: Self = Self {
        full_scale_code: 1 << 15,
        r_ref_ohm: 400.0,
    };
    /// MAX31865 with a 4 kΩ (4·R0) reference for a PT1000.
    pub const MAX31865_PT1000: Self = Self {
        full_scale_code: 1 << 15,
        r_ref_ohm: 4000.0,
    };

    /// The fields are public, so every use re-checks them.
    fn validate(&self) -> Result<(), RtdError> {
        if self.full_scale_code == 0 || !self.r_ref_ohm.is_finite() || self.r_ref_ohm <= 0.0 {
            Err(RtdError::InvalidParameter)
        } else {
            Ok(())
        }
    }

    /// Resistance of one code step, in Ω.
    pub fn lsb_ohm(&self) -> Result<f64, RtdError> {
        self.validate()?;
        Ok(self.r_ref_ohm / f64::from(self.full_scale_code))
    }

    /// Resistance for a raw code, in Ω.
    pub fn resistance_ohm(&self, code: RtdCode) -> Result<f64, RtdError> {
        self.validate()?;
        if code.0 >= self.full_scale_code {
            return Err(RtdError::CodeOutOfRange);
        }
        Ok(f64::from(code.0) / f64::from(self.full_scale_code) * self.r_ref_ohm)
    }

    /// The code nearest to `r_ohm`, saturating at 0 and at the top code as
    /// the converter itself would; for simulation and tests.
    pub fn code_for_resistance(&self, r_ohm: f64) -> Result<RtdCode, RtdError> {
        self.validate()?;
        if !r_ohm.is_finite() {
            return Err(RtdError::NonFinite);
        }
        let top_code = self.full_scale_code.saturating_sub(1);
        let nearest = libm::round(r_ohm / self.r_ref_ohm * f64::from(self.full_scale_code));
        let code = if nearest <= 0.0 {
            0
        } else if nearest >= f64::from(top_code) {
            top_code
        } else {
            // `nearest` is a whole number strictly inside 0..top_code, so
            // the conversion is exact.
            nearest as u32
        };
        Ok(RtdCode(code))
    }
}

/// One converter channel: element, converter and fault limits, turning a
/// raw code straight into a temperature or a fault.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RtdChannel {
    /// The RTD element.
    pub rtd: Rtd,
    /// The converter reading it.
    pub adc: Ratiometric,
    /// Open/short limits.
    pub faults: FaultThresholds,
}

impl RtdChannel {
    /// PT100 on a MAX31865 with a 400 Ω reference and default fault limits.
    pub const MAX31865_PT100: Self = Self {
        rtd: Rtd::PT100,
        adc: Ratiometric::MAX31865_PT100,
        faults: FaultThresholds::DEFAULT,
    };
    /// PT1000 on a MAX31865 with a 4 kΩ reference and default fault limits.
    pub const MAX31865_PT1000: Self = Self {
        rtd: Rtd::PT1000,
        adc: Ratiometric::MAX31865_PT1000,
        faults: FaultThresholds::DEFAULT,
    };

    /// Temperature for a raw code, in °C, or the fault the code shows.
    pub fn temperature_c(&self, code: RtdCode) -> Result<f64, RtdError> {
        let r_ohm = self.adc.resistance_ohm(code)?;
        self.rtd.classify(r_ohm, Some(&self.adc), &self.faults)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn r0_at_zero_and_coefficients_at_100_c() {
        // R(0) = R0 exactly: the polynomial is 1 + 0 + 0.
        assert_eq!(Rtd::PT100.resistance_ohm(0.0), Ok(100.0));
        // R(100)/R0 = 1 + 100 A + 1e4 B = 1.385055; 1e-12 Ω is a few ulps
        // of 138 Ω, enough for the two roundings in the polynomial.
        let r = Rtd::PT100.resistance_ohm(100.0).unwrap_or(f64::NAN);
        assert!((r - 138.5055).abs() < 1e-12, "{r}");
    }

    #[test]
    fn c_term_only_below_zero() {
        // At −100 °C the C term is C·(−200)·(−1e6) = −8.366e-4 of R0; its
        // absence would put R 0.0837 Ω higher. Tolerance: a few ulps.
        let r = Rtd::PT100.resistance_ohm(-100.0).unwrap_or(f64::NAN);
        let expected = 100.0 * (1.0 - 0.390_83 - 0.005_775 - 8.366e-4);
        assert!((r - expected).abs() < 1e-12, "{r} vs {expected}");
    }

    #[test]
    fn inverse_is_continuous_across_r0() {
        // Both branches must meet at 0 °C; one ulp either side of R0 must
        // give |T| of order ulp/slope ≈ 1e-14/3.9e-3 °C, far below 1e-9.
        let below = Rtd::PT100.temperature_c(100.0 - 1e-12).unwrap_or(f64::NAN);
        let above = Rtd::PT100.temperature_c(100.0 + 1e-12).unwrap_or(f64::NAN);
        assert!(below < 0.0 && below > -1e-9, "{below}");
        assert!(above > 0.0 && above < 1e-9, "{above}");
        assert_eq!(Rtd::PT100.temperature_c(100.0), Ok(0.0));
    }

    #[test]
    fn newton_beats_the_quadratic_start() {
        // At −150 °C the quadratic start is ~0.84 °C off (the C term is
        // −3.5e-3 of R0); Newton must remove that to its 1e-9 °C stopping
        // step, or the C term was ignored. (At −200 °C the clamp to the
        // range would hide a missing Newton step.)
        let r = Rtd::PT100.resistance_ohm(-150.0).unwrap_or(f64::NAN);
        let start = quadratic_root_c(r / 100.0);
        assert!((start + 150.0).abs() > 0.5, "{start}");
        let t = Rtd::PT100.temperature_c(r).unwrap_or(f64::NAN);
        assert!((t + 150.0).abs() < 1e-9, "{t}");
    }

    #[test]
    fn tiny_temperatures_keep_relative_precision() {
        // 1 µ°C above zero. The textbook root (−A + √…)/(2B) cancels here
        // and is off by ~ε·A/|B| ≈ 4e-13 °C, i.e. 4e-7 relative; the stable
        // form keeps ~1e-15, so 1e-12 relative separates the two.
        let t_c = 1e-6;
        let r = Rtd::PT100.resistance_ohm(t_c).unwrap_or(f64::NAN);
        let back = Rtd::PT100.temperature_c(r).unwrap_or(f64::NAN);
        // The rounding of R and of R/R0 moves T by ~1e-8 relative, the
        // same in both, so the reference takes the same x = R/R0 − 1 (exact
        // by Sterbenz) and solves A·T + B·T² = x by its series
        // T = (x/A)(1 − B·x/A²), whose next term is ~1e-26 relative.
        let x = r / 100.0 - 1.0;
        let exact = x / CVD_A * (1.0 - CVD_B * x / (CVD_A * CVD_A));
        assert!((back - exact).abs() < 1e-12 * exact, "{back} vs {exact}");
    }

    #[test]
    fn range_edges() {
        let rtd = Rtd::PT100;
        assert_eq!(rtd.temperature_c(rtd.r_min_ohm()), Ok(T_MIN_C));
        assert_eq!(rtd.temperature_c(rtd.r_max_ohm()), Ok(T_MAX_C));
        assert_eq!(
            rtd.resistance_ohm(-200.000_001),
            Err(RtdError::TemperatureOutOfRange)
        );
        assert_eq!(
            rtd.resistance_ohm(850.000_001),
            Err(RtdError::TemperatureOutOfRange)
        );
        assert_eq!(
            rtd.temperature_c(rtd.r_max_ohm() + 1e-9),
            Err(RtdError::ResistanceOutOfRange)
        );
        assert_eq!(
            rtd.temperature_c(rtd.r_min_ohm() - 1e-9),
            Err(RtdError::ResistanceOutOfRange)
        );
        assert_eq!(rtd.resistance_ohm(f64::NAN), Err(RtdError::NonFinite));
        assert_eq!(rtd.temperature_c(f64::INFINITY), Err(RtdError::NonFinite));
    }

    #[test]
    fn custom_r0() {
        assert_eq!(Rtd::new(0.0), Err(RtdError::InvalidParameter));
        assert_eq!(Rtd::new(-100.0), Err(RtdError::InvalidParameter));
        assert_eq!(Rtd::new(f64::NAN), Err(RtdError::NonFinite));
        assert_eq!(Rtd::new(f64::MAX), Err(RtdError::InvalidParameter));
        assert_eq!(Rtd::new(f64::MIN_POSITIVE), Err(RtdError::InvalidParameter));
        // A PT500 scales the PT100 curve by exactly 5 (R0 is a factor).
        let pt500 = Rtd::new(500.0).unwrap_or(Rtd::PT100);
        let r500 = pt500.resistance_ohm(321.0).unwrap_or(f64::NAN);
        let r100 = Rtd::PT100.resistance_ohm(321.0).unwrap_or(f64::NAN);
        assert!((r500 - 5.0 * r100).abs() < 1e-12 * r500);
    }

    #[test]
    fn ratiometric_codes() {
        let adc = Ratiometric::MAX31865_PT100;
        // 400 Ω / 2^15 = 12.2070 mΩ per code.
        assert_eq!(adc.lsb_ohm(), Ok(400.0 / 32768.0));
        assert_eq!(adc.resistance_ohm(RtdCode(8192)), Ok(100.0));
        assert_eq!(
            adc.resistance_ohm(RtdCode(32768)),
            Err(RtdError::CodeOutOfRange)
        );
        assert_eq!(adc.code_for_resistance(100.0), Ok(RtdCode(8192)));
        // Nearest code: 100 Ω + 0.49 LSB rounds down, + 0.51 LSB up.
        let lsb = 400.0 / 32768.0;
        assert_eq!(
            adc.code_for_resistance(100.0 + 0.49 * lsb),
            Ok(RtdCode(8192))
        );
        assert_eq!(
            adc.code_for_resistance(100.0 + 0.51 * lsb),
            Ok(RtdCode(8193))
        );
        // Saturation, as the converter would.
        assert_eq!(adc.code_for_resistance(-5.0), Ok(RtdCode(0)));
        assert_eq!(adc.code_for_resistance(1e9), Ok(RtdCode(32767)));
        assert_eq!(adc.code_for_resistance(f64::NAN), Err(RtdError::NonFinite));
        let broken = Ratiometric {
            full_scale_code: 0,
            r_ref_ohm: 400.0,
        };
        assert_eq!(
            broken.resistance_ohm(RtdCode(0)),
            Err(RtdError::InvalidParameter)
        );
        let broken = Ratiometric {
            full_scale_code: 1,
            r_ref_ohm: f64::NAN,
        };
        assert_eq!(
            broken.code_for_resistance(1.0),
            Err(RtdError::InvalidParameter)
        );
    }

    #[test]
    fn classify_orders_faults() {
        let rtd = Rtd::PT100;
        let th = FaultThresholds::DEFAULT;
        // Without a converter, open starts at 2·R(850) = 780.96 Ω.
        assert_eq!(rtd.classify(781.0, None, &th), Err(RtdError::Open));
        assert_eq!(
            rtd.classify(780.0, None, &th),
            Err(RtdError::ResistanceOutOfRange)
        );
        // With the 400 Ω converter, open starts at 0.99·400 = 396 Ω.
        let adc = Ratiometric::MAX31865_PT100;
        assert_eq!(rtd.classify(396.0, Some(&adc), &th), Err(RtdError::Open));
        assert_eq!(
            rtd.classify(395.9, Some(&adc), &th),
            Err(RtdError::ResistanceOutOfRange)
        );
        // Short below 0.5·R(−200) = 9.26 Ω.
        assert_eq!(rtd.classify(9.25, None, &th), Err(RtdError::Short));
        assert_eq!(
            rtd.classify(9.27, None, &th),
            Err(RtdError::ResistanceOutOfRange)
        );
        assert_eq!(rtd.classify(100.0, Some(&adc), &th), Ok(0.0));
        let bad = FaultThresholds {
            short_factor_of_r_min: f64::NAN,
            ..th
        };
        assert_eq!(
            rtd.classify(100.0, None, &bad),
            Err(RtdError::InvalidParameter)
        );
    }

    #[test]
    fn display_names_the_fault() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(RtdError::Open.to_string(), "RTD open circuit");
        assert_eq!(RtdError::Short.to_string(), "RTD short circuit");
    }
}
