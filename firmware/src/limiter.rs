//! The last stage before the CNC: every offset is clamped to a range and
//! slew-limited to a rate, per output, whatever the stages before it did.
//!
//! # Method
//!
//! For output `i`, from the last reported value `prev` (within the clamp)
//! and a target:
//!
//! ```text
//! t   = clamp(target, -clamp_um[i], +clamp_um[i])     (NaN/inf: t = prev)
//! out = prev + clamp(t - prev, -step, +step),  step = slew_um_per_s[i] * dt_s
//! ```
//!
//! Clamping the target first and then stepping towards it keeps `out`
//! between `prev` and `t`, so it is within the clamp and moved by at most
//! `step`; a target within reach is returned exactly (no rounding drift).
//! CNC controls limit externally applied offsets the same way (a maximum
//! value and a maximum change per interpolation cycle), so the hub's
//! output already respects what the control would otherwise refuse or jerk.

use crate::config::{positive, ConfigError};
use crate::offsets::MAX_OUTPUTS;

/// Per-output slew rate and clamp (offsets in um, rates in um/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimiterConfig {
    /// Largest change of each output per second, um/s.
    pub slew_um_per_s: [f64; MAX_OUTPUTS],
    /// Largest magnitude of each output, um.
    pub clamp_um: [f64; MAX_OUTPUTS],
}

impl LimiterConfig {
    /// Default slew rate, um/s. Thermal drift at the tool centre point is
    /// tens of um over tens of minutes (seed 001: 39.6 um axial elongation;
    /// seed 004: up to 90 um), i.e. well under 0.1 um/s, so 2 um/s never
    /// lags a healthy model, while any jump (model swap, tool change, a spike
    /// that got through) reaches the axis as at most 2 um per 1 s sample:
    /// within a finishing tolerance, so no step mark on a machined surface.
    pub const DEFAULT_SLEW_UM_PER_S: f64 = 2.0;

    /// Default clamp, um. More than 5x the largest thermal error in the
    /// seeds (90 um, seed 004), so it never cuts a real correction, yet it
    /// caps what a wrong model can do to half a millimetre, which the first
    /// measured part shows, rather than a crash into the work.
    pub const DEFAULT_CLAMP_UM: f64 = 500.0;

    /// Every output gets the default rate and clamp.
    pub const DEFAULT: Self = Self {
        slew_um_per_s: [Self::DEFAULT_SLEW_UM_PER_S; MAX_OUTPUTS],
        clamp_um: [Self::DEFAULT_CLAMP_UM; MAX_OUTPUTS],
    };

    /// Checks every output's rate and clamp once; [`limit`] then has only
    /// finite, positive bounds to work with.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (i, (rate, clamp)) in self.slew_um_per_s.iter().zip(&self.clamp_um).enumerate() {
            // MAX_OUTPUTS is 4, so the index fits a u8.
            let output = u8::try_from(i).unwrap_or(u8::MAX);
            if !positive(*rate) {
                return Err(ConfigError::SlewRate { output });
            }
            if !positive(*clamp) {
                return Err(ConfigError::Clamp { output });
            }
        }
        Ok(())
    }

    /// The slowest slew rate over all outputs, um/s.
    pub fn min_slew_um_per_s(&self) -> f64 {
        self.slew_um_per_s
            .iter()
            .fold(f64::INFINITY, |a, b| a.min(*b))
    }
}

impl Default for LimiterConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One limited output value and what the limiter did to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limited {
    /// The value to report, um: finite, within the clamp, within one step
    /// of the previous value.
    pub value_um: f64,
    /// The target was beyond the clamp.
    pub clamped: bool,
    /// The target was more than one step away.
    pub slew_limited: bool,
}

/// Moves `prev_um` towards `target_um` by at most `step_um`, within
/// `+-clamp_um` (see the module doc). A non-finite target holds `prev_um`.
///
/// `step_um` and `clamp_um` come from a validated [`LimiterConfig`]
/// (positive; `step_um` may be infinite for an absurd sample period, which
/// only removes the slew limit). Whatever the arguments, the result is
/// finite: a clamp that is not finite counts as zero, and a `prev_um` that
/// is not finite (it is the limiter's own last output, so never) restarts
/// from zero.
pub fn limit(prev_um: f64, target_um: f64, step_um: f64, clamp_um: f64) -> Limited {
    // Defensive: a NaN bound would poison `clamp`/comparisons below, and an
    // infinite clamp would let an infinite target through.
    let clamp_um = if clamp_um.is_finite() {
        clamp_um.abs()
    } else {
        0.0
    };
    let step_um = if step_um.is_nan() { 0.0 } else { step_um.abs() };
    let prev = if prev_um.is_finite() {
        prev_um.clamp(-clamp_um, clamp_um)
    } else {
        0.0
    };
    let (t, clamped) = if target_um.is_nan() {
        (prev, false)
    } else {
        let t = target_um.clamp(-clamp_um, clamp_um);
        (t, t != target_um)
    };
    let delta = t - prev;
    let (value, slew_limited) = if delta > step_um {
        (prev + step_um, true)
    } else if delta < -step_um {
        (prev - step_um, true)
    } else {
        (t, false)
    };
    Limited {
        // `prev +- step` may round past the clamp by an ulp, and an infinite
        // step makes it infinite: the final clamp settles both.
        value_um: value.clamp(-clamp_um, clamp_um),
        clamped,
        slew_limited,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn within_reach_is_exact() {
        let l = limit(10.0, 11.5, 2.0, 500.0);
        assert_eq!(
            l,
            Limited {
                value_um: 11.5,
                clamped: false,
                slew_limited: false
            }
        );
        // Exactly one step is not "slew limited".
        assert_eq!(limit(10.0, 12.0, 2.0, 500.0).value_um, 12.0);
        assert!(!limit(10.0, 12.0, 2.0, 500.0).slew_limited);
    }

    #[test]
    fn slew_limit_is_exact_both_ways() {
        let l = limit(10.0, 100.0, 2.0, 500.0);
        assert_eq!((l.value_um, l.slew_limited, l.clamped), (12.0, true, false));
        let l = limit(10.0, -100.0, 2.0, 500.0);
        assert_eq!((l.value_um, l.slew_limited), (8.0, true));
    }

    #[test]
    fn clamp_is_exact_and_flagged() {
        let l = limit(499.0, 1e6, 2.0, 500.0);
        assert_eq!(
            (l.value_um, l.clamped, l.slew_limited),
            (500.0, true, false)
        );
        let l = limit(-500.0, -600.0, 2.0, 500.0);
        assert_eq!(
            (l.value_um, l.clamped, l.slew_limited),
            (-500.0, true, false)
        );
        // Clamped and slew limited at once.
        let l = limit(0.0, f64::INFINITY, 2.0, 500.0);
        assert_eq!((l.value_um, l.clamped, l.slew_limited), (2.0, true, true));
    }

    #[test]
    fn nan_target_holds_and_bad_prev_restarts_at_zero() {
        assert_eq!(limit(7.0, f64::NAN, 2.0, 500.0).value_um, 7.0);
        assert_eq!(limit(f64::NAN, 100.0, 2.0, 500.0).value_um, 2.0);
        assert_eq!(limit(0.0, 3.0, f64::INFINITY, 500.0).value_um, 3.0);
        assert_eq!(limit(0.0, 1e9, f64::INFINITY, 500.0).value_um, 500.0);
    }

    #[test]
    fn defaults_valid_and_bad_values_name_the_output() {
        assert_eq!(LimiterConfig::DEFAULT.validate(), Ok(()));
        assert_eq!(LimiterConfig::DEFAULT.min_slew_um_per_s(), 2.0);
        let mut c = LimiterConfig::DEFAULT;
        c.slew_um_per_s[2] = 0.0;
        assert_eq!(c.validate(), Err(ConfigError::SlewRate { output: 2 }));
        let mut c = LimiterConfig::DEFAULT;
        c.clamp_um[3] = f64::INFINITY;
        assert_eq!(c.validate(), Err(ConfigError::Clamp { output: 3 }));
    }
}
