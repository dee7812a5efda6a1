//! Why a pipeline setting is refused, shared by the spike filter, the
//! supervisor and the limiter, and the one conversion from a duration to a
//! whole number of samples that they all use.
//!
//! Settings are checked once (`validate`, STYLE habit 4); after that the
//! per-sample code never fails, so every check that can fail lives here or in
//! a `validate` that returns this error.

use core::fmt;

/// A setting that cannot run: which one, so a host tool or a log can name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ConfigError {
    /// The sample period is not finite and positive.
    SamplePeriod,
    /// The spike filter's physical rate is not finite and positive.
    SpikeRate,
    /// The spike filter's noise allowance is not finite and non-negative.
    SpikeNoise,
    /// The spike filter must see a new level at least once to accept it.
    SpikePersist,
    /// The hold time is not finite and non-negative.
    HoldTime,
    /// The ramp-to-zero rate is not finite and positive.
    RampRate,
    /// The recovery time is not finite and non-negative.
    RecoverTime,
    /// The flap window is not finite and non-negative.
    FlapWindow,
    /// The plausibility window is not finite or empty.
    PlausibleWindow,
    /// The plausible rate or its window is not finite and positive.
    PlausibleRate,
    /// The stuck time is not finite and non-negative.
    StuckTime,
    /// The ramp is faster than an output's slew limit, so the limiter, not
    /// the configured ramp, would set the rate.
    RampFasterThanSlew {
        /// The output whose slew limit is slower.
        output: u8,
    },
    /// An output's slew rate is not finite and positive.
    SlewRate {
        /// The output.
        output: u8,
    },
    /// An output's clamp is not finite and positive.
    Clamp {
        /// The output.
        output: u8,
    },
    /// A commanded tool length is not finite or outside its range.
    ToolLength,
    /// The travel that scales slope limits is not finite and positive.
    SlopeStroke,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::SamplePeriod => write!(f, "sample period must be finite and > 0 s"),
            Self::SpikeRate => write!(f, "spike max rate must be finite and > 0 K/s"),
            Self::SpikeNoise => write!(f, "spike noise allowance must be finite and >= 0 K"),
            Self::SpikePersist => write!(f, "spike persist count must be >= 1 sample"),
            Self::HoldTime => write!(f, "hold time must be finite and >= 0 s"),
            Self::RampRate => write!(f, "ramp rate must be finite and > 0 um/s"),
            Self::RecoverTime => write!(f, "recovery time must be finite and >= 0 s"),
            Self::FlapWindow => write!(f, "flap window must be finite and >= 0 s"),
            Self::PlausibleWindow => write!(f, "plausible temperatures must be finite, min < max"),
            Self::PlausibleRate => {
                write!(f, "plausible rate and its window must be finite and > 0")
            }
            Self::StuckTime => write!(f, "stuck time must be finite and >= 0 s"),
            Self::RampFasterThanSlew { output } => {
                write!(f, "ramp rate exceeds the slew rate of output #{output}")
            }
            Self::SlewRate { output } => {
                write!(
                    f,
                    "slew rate of output #{output} must be finite and > 0 um/s"
                )
            }
            Self::Clamp { output } => {
                write!(f, "clamp of output #{output} must be finite and > 0 um")
            }
            Self::ToolLength => write!(f, "tool length must be finite and within 0..=1000 mm"),
            Self::SlopeStroke => write!(f, "slope stroke must be finite and > 0 mm"),
        }
    }
}

impl core::error::Error for ConfigError {}

/// Whether `v` is finite and strictly positive.
pub(crate) fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// Whether `v` is finite and not negative.
pub(crate) fn non_negative(v: f64) -> bool {
    v.is_finite() && v >= 0.0
}

/// Relative slack when turning a duration into samples: `60 s / 0.1 s` is
/// 599.999... or 600.000...1 in binary; both must mean 600 samples.
const SAMPLES_RTOL: f64 = 1e-9;

/// The smallest whole number of samples of `dt_s` that lasts at least
/// `duration_s`, i.e. `ceil(duration_s / dt_s)` with a relative slack of
/// `SAMPLES_RTOL` (1e-9) so that rounding in the division cannot add a sample.
/// Saturates at `u32::MAX` (about 136 years at 1 s); 0 for a zero, negative
/// or non-finite duration, or a period that is not finite and positive.
pub fn samples_for(duration_s: f64, dt_s: f64) -> u32 {
    if !positive(duration_s) || !positive(dt_s) {
        return 0;
    }
    let ratio = duration_s / dt_s;
    // `as` saturates (NaN -> 0, huge -> MAX); ratio is positive here.
    let whole = ratio as u32;
    if f64::from(whole) >= ratio * (1.0 - SAMPLES_RTOL) {
        whole
    } else {
        whole.saturating_add(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_for_rounds_up_with_slack() {
        assert_eq!(samples_for(60.0, 1.0), 60);
        assert_eq!(samples_for(60.0, 0.1), 600);
        assert_eq!(samples_for(0.3, 0.1), 3);
        assert_eq!(samples_for(60.5, 1.0), 61);
        assert_eq!(samples_for(0.5, 1.0), 1);
        assert_eq!(samples_for(0.0, 1.0), 0);
        assert_eq!(samples_for(1e300, 1e-300), u32::MAX);
        assert_eq!(samples_for(f64::NAN, 1.0), 0);
        assert_eq!(samples_for(1.0, 0.0), 0);
    }

    #[test]
    fn display_names_the_setting() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(
            ConfigError::SlewRate { output: 2 }.to_string(),
            "slew rate of output #2 must be finite and > 0 um/s"
        );
    }
}
