//! Fault handling: what the offsets do while the inputs or the model are bad.
//!
//! # Method
//!
//! One supervisor per model output (see `pipeline`). A sample is *good* for
//! an output when every input the output reads was read and passed the
//! spike filter, and the model produced finite outputs. On a bad sample
//! (open or shorted RTD, bus error, stale reading, rejected spike, model
//! refusal) the supervisor moves through
//!
//! ```text
//! Running --bad--> Holding --hold_time_s--> Ramping --offsets at 0--> Zeroed
//!    ^                |                        |                        |
//!    +-----good-------+   good for recover_time_s in a row (failed) ----+
//! ```
//!
//! * Holding: the offsets last sent stay as they are. Thermal error changes
//!   over minutes, so for a short fault (a connector, a bus glitch) the last
//!   offsets are closer to the truth than none.
//! * Ramping: once the fault has lasted `hold_time_s`, stale compensation
//!   may be worse than none, so each offset moves to zero at
//!   `ramp_um_per_s`, never as a step.
//! * From Holding, a good sample returns to Running at once: a glitch is
//!   over. Once the hold time has run out the input is *failed*, and it
//!   must read good for `recover_time_s` in a row before the offsets follow
//!   the model again (until then they keep ramping or stay at zero): an
//!   intermittent contact that reads good one second in five would
//!   otherwise switch the compensation on and off all day.
//! * Faults are also counted: the `flap_faults`-th separate fault (a bad
//!   sample after a good one) within `flap_window_s` of the first fails the
//!   input at once, even if no fault lasted the hold time: a contact bad
//!   every second sample would otherwise alternate Holding/Running forever
//!   and never ramp. It then recovers like any failed input. The window is
//!   a fixed one, started by the first fault after the last window ran out
//!   (two counters per output, no history buffer).
//! * Either way the slew limiter takes the offsets from wherever they are
//!   to the model's value, so there is no jump in either direction.
//!
//! Timing counts samples, not seconds: a fault starting at sample `k` holds
//! for samples `k .. k + H - 1` with `H = ceil(hold_time_s / dt_s)`, and the
//! first ramp step is taken at sample `k + H` (see `config::samples_for`).
//!
//! While an input is lost the model steps on with its last good value
//! standing in (see `pipeline`), whether or not some output still reads
//! only good inputs: the healthy outputs stay exact, the memories of the
//! good inputs keep following them, and the outputs that read the lost
//! input see the held value. On its return a temperature's filter-bank
//! memories are mended as if it had moved along a line meanwhile
//! (`ValidModel::bridge`); a TF or ARX model takes the change as one step
//! at recovery, an error that is small for faults short against the
//! thermal time constants (minutes to hours), smoothed by the recovery
//! time and the slew limit; a CNC input that comes back at another value
//! makes its outputs wait until their memories have forgotten the
//! stand-in (`pipeline`, the settle wait).

use crate::config::{non_negative, positive, samples_for, ConfigError};
use crate::report::HubState;

/// Hold time and ramp rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SupervisorConfig {
    /// How long a fault holds the last offsets before they ramp to zero, s.
    pub hold_time_s: f64,
    /// How fast offsets ramp to zero after the hold time, um/s. Must not
    /// exceed any output's slew rate (checked by the pipeline's config).
    pub ramp_um_per_s: f64,
    /// How long a failed input (fault past the hold time) must read good
    /// in a row before the offsets follow the model again, s.
    pub recover_time_s: f64,
    /// Window over which separate faults are counted, s.
    pub flap_window_s: f64,
    /// Separate faults within the window that fail the input (ramp), 0: off.
    pub flap_faults: u8,
}

impl SupervisorConfig {
    /// The defaults, with their reasons:
    ///
    /// * `hold_time_s = 60`: a loose connector, a bus glitch or an EMI burst
    ///   clears in seconds; over 60 s the thermal error moves by well under a
    ///   micrometre (drift < 0.1 um/s, see `limiter`), so holding is better
    ///   than dropping compensation. A sensor still dead after a minute is a
    ///   real failure: stop trusting the held value.
    /// * `ramp_um_per_s = 1`: half the default slew rate, so the ramp is the
    ///   configured one, not the limiter's; a typical 20-50 um offset reaches
    ///   zero in under a minute, without a step on the part.
    /// * `recover_time_s = 10`: a reconnected sensor is stable within a
    ///   second; ten seconds of good readings in a row rule out a contact
    ///   that flickers, and cost well under 1 um of thermal drift.
    /// * `flap_window_s = 60`, `flap_faults = 5`: seed 002's worst burst of
    ///   spikes is three in about three minutes; five separate faults in a
    ///   minute is a bad contact, not a glitch, and is failed on the spot.
    pub const DEFAULT: Self = Self {
        hold_time_s: 60.0,
        ramp_um_per_s: 1.0,
        recover_time_s: 10.0,
        flap_window_s: 60.0,
        flap_faults: 5,
    };

    /// Checks the settings once.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !non_negative(self.hold_time_s) {
            return Err(ConfigError::HoldTime);
        }
        if !positive(self.ramp_um_per_s) {
            return Err(ConfigError::RampRate);
        }
        if !non_negative(self.recover_time_s) {
            return Err(ConfigError::RecoverTime);
        }
        if !non_negative(self.flap_window_s) {
            return Err(ConfigError::FlapWindow);
        }
        Ok(())
    }

    /// The recovery time in whole samples of `dt_s` (rounded up).
    pub fn recover_samples(&self, dt_s: f64) -> u32 {
        samples_for(self.recover_time_s, dt_s)
    }

    /// The flap window in whole samples of `dt_s` (rounded up).
    pub fn flap_window_samples(&self, dt_s: f64) -> u32 {
        samples_for(self.flap_window_s, dt_s)
    }

    /// The hold time in whole samples of `dt_s` (rounded up).
    pub fn hold_samples(&self, dt_s: f64) -> u32 {
        samples_for(self.hold_time_s, dt_s)
    }

    /// How far an offset ramps per sample of `dt_s`, um.
    pub fn ramp_step_um(&self, dt_s: f64) -> f64 {
        self.ramp_um_per_s * dt_s
    }
}

impl Default for SupervisorConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What the offsets do this sample, mildest first (`Ord`: the worst of
/// several outputs' phases is the hub's state).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Phase {
    /// Follow the model (through the limiter).
    Follow,
    /// Keep the offsets last sent.
    Hold,
    /// Move each offset one ramp step towards zero.
    Ramp,
}

impl Phase {
    /// The state to report, given whether every offset is now zero.
    pub fn hub_state(self, offsets_zero: bool) -> HubState {
        match self {
            Self::Follow => HubState::Running,
            Self::Hold => HubState::Holding,
            Self::Ramp if offsets_zero => HubState::Zeroed,
            Self::Ramp => HubState::Ramping,
        }
    }
}

/// A [`SupervisorConfig`] in whole samples of one period.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SupervisorSamples {
    /// [`SupervisorConfig::hold_samples`].
    pub hold: u32,
    /// [`SupervisorConfig::recover_samples`].
    pub recover: u32,
    /// [`SupervisorConfig::flap_window_samples`].
    pub flap_window: u32,
    /// [`SupervisorConfig::flap_faults`] (0: no fault counting).
    pub flap_faults: u8,
}

impl SupervisorSamples {
    /// `config` at a sample period of `dt_s`.
    pub fn new(config: &SupervisorConfig, dt_s: f64) -> Self {
        Self {
            hold: config.hold_samples(dt_s),
            recover: config.recover_samples(dt_s),
            flap_window: config.flap_window_samples(dt_s),
            flap_faults: config.flap_faults,
        }
    }
}

/// The fault timer: consecutive bad samples, good ones after a failure,
/// and separate faults in the current flap window.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Supervisor {
    bad_run: u32,
    good_run: u32,
    failed: bool,
    /// Samples left in the flap window (0: no window open).
    window_left: u32,
    /// Separate faults since the window opened.
    faults: u8,
}

impl Supervisor {
    /// No fault seen.
    pub const NEW: Self = Self {
        bad_run: 0,
        good_run: 0,
        failed: false,
        window_left: 0,
        faults: 0,
    };

    /// One sample: `good` as in the module doc; `n` from
    /// [`SupervisorSamples::new`].
    pub fn step(&mut self, good: bool, n: &SupervisorSamples) -> Phase {
        self.window_left = self.window_left.saturating_sub(1);
        if !good && self.bad_run == 0 && n.flap_faults > 0 {
            // A new fault: count it in the window (opening one if none).
            if self.window_left == 0 {
                self.window_left = n.flap_window;
                self.faults = 0;
            }
            self.faults = self.faults.saturating_add(1);
            if self.faults >= n.flap_faults {
                self.failed = true;
            }
        }
        let (hold_samples, recover_samples) = (n.hold, n.recover);
        if good {
            self.good_run = self.good_run.saturating_add(1);
            if self.failed && self.good_run < recover_samples {
                return Phase::Ramp;
            }
            if self.failed {
                // Recovered: a new count starts with the next fault.
                self.window_left = 0;
                self.faults = 0;
            }
            self.failed = false;
            self.bad_run = 0;
            return Phase::Follow;
        }
        self.good_run = 0;
        let before = self.bad_run;
        self.bad_run = self.bad_run.saturating_add(1);
        if before < hold_samples && !self.failed {
            Phase::Hold
        } else {
            self.failed = true;
            Phase::Ramp
        }
    }

    /// Consecutive bad samples up to and including the last one (0 after a
    /// good sample, and after recovery from a failure).
    pub fn bad_run(&self) -> u32 {
        self.bad_run
    }
}

/// `prev_um` moved `step_um` towards zero, landing exactly on zero.
pub fn ramp_toward_zero(prev_um: f64, step_um: f64) -> f64 {
    if !prev_um.is_finite() || prev_um.abs() <= step_um {
        0.0
    } else if prev_um > 0.0 {
        prev_um - step_um
    } else {
        prev_um + step_um
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hold and recovery counts, no fault counting.
    fn n(hold: u32, recover: u32) -> SupervisorSamples {
        SupervisorSamples {
            hold,
            recover,
            flap_window: 0,
            flap_faults: 0,
        }
    }

    /// The 5th separate fault within the window fails the input at once;
    /// four do not, and a window that ran out starts the count again.
    #[test]
    fn counted_faults_fail_a_flapping_input() {
        let c = SupervisorSamples {
            hold: 60,
            recover: 3,
            flap_window: 10,
            flap_faults: 5,
        };
        let mut s = Supervisor::NEW;
        for _ in 0..4 {
            assert_eq!(s.step(false, &c), Phase::Hold);
            assert_eq!(s.step(true, &c), Phase::Follow);
        }
        // Window (10 samples from the first fault) runs out: count restarts.
        assert_eq!(s.step(true, &c), Phase::Follow);
        assert_eq!(s.step(true, &c), Phase::Follow);
        for _ in 0..4 {
            assert_eq!(s.step(false, &c), Phase::Hold);
            assert_eq!(s.step(true, &c), Phase::Follow);
        }
        assert_eq!(s.step(false, &c), Phase::Ramp, "5th fault in 10 samples");
        assert_eq!(s.step(true, &c), Phase::Ramp);
        assert_eq!(s.step(true, &c), Phase::Ramp);
        assert_eq!(s.step(true, &c), Phase::Follow, "3 good in a row");
        assert_eq!(s.step(false, &c), Phase::Hold, "count restarted");
    }

    #[test]
    fn holds_exactly_hold_samples_then_ramps_then_recovers() {
        let cfg = SupervisorConfig {
            hold_time_s: 5.0,
            ramp_um_per_s: 1.0,
            recover_time_s: 0.0,
            ..SupervisorConfig::DEFAULT
        };
        let hold = cfg.hold_samples(1.0);
        assert_eq!(hold, 5);
        let mut s = Supervisor::NEW;
        assert_eq!(s.step(true, &n(hold, 0)), Phase::Follow);
        for _ in 0..5 {
            assert_eq!(s.step(false, &n(hold, 0)), Phase::Hold);
        }
        assert_eq!(s.step(false, &n(hold, 0)), Phase::Ramp);
        assert_eq!(s.bad_run(), 6);
        assert_eq!(s.step(true, &n(hold, 0)), Phase::Follow);
        assert_eq!(s.bad_run(), 0);
        // A new fault starts a new hold.
        assert_eq!(s.step(false, &n(hold, 0)), Phase::Hold);
    }

    /// A glitch inside the hold time recovers at the first good sample; a
    /// failed input needs `recover` good samples in a row, and a bad one
    /// among them starts the count again (still ramping, no new hold).
    #[test]
    fn a_failed_input_must_read_good_for_the_recovery_time() {
        let (hold, recover) = (3, 4);
        let mut s = Supervisor::NEW;
        assert_eq!(s.step(false, &n(hold, recover)), Phase::Hold);
        assert_eq!(s.step(true, &n(hold, recover)), Phase::Follow, "glitch");
        for _ in 0..3 {
            assert_eq!(s.step(false, &n(hold, recover)), Phase::Hold);
        }
        assert_eq!(s.step(false, &n(hold, recover)), Phase::Ramp, "failed");
        for _ in 0..3 {
            assert_eq!(s.step(true, &n(hold, recover)), Phase::Ramp, "proving");
        }
        assert_eq!(s.step(false, &n(hold, recover)), Phase::Ramp, "flicker");
        for _ in 0..3 {
            assert_eq!(s.step(true, &n(hold, recover)), Phase::Ramp);
        }
        assert_eq!(s.step(true, &n(hold, recover)), Phase::Follow, "4 in a row");
        assert_eq!(s.step(false, &n(hold, recover)), Phase::Hold, "a new hold");
    }

    #[test]
    fn zero_hold_ramps_at_once() {
        let mut s = Supervisor::NEW;
        assert_eq!(s.step(false, &n(0, 0)), Phase::Ramp);
    }

    #[test]
    fn states_for_phases() {
        assert_eq!(Phase::Follow.hub_state(true), HubState::Running);
        assert_eq!(Phase::Hold.hub_state(true), HubState::Holding);
        assert_eq!(Phase::Ramp.hub_state(false), HubState::Ramping);
        assert_eq!(Phase::Ramp.hub_state(true), HubState::Zeroed);
    }

    #[test]
    fn ramp_lands_on_zero() {
        assert_eq!(ramp_toward_zero(2.5, 1.0), 1.5);
        assert_eq!(ramp_toward_zero(-2.5, 1.0), -1.5);
        assert_eq!(ramp_toward_zero(0.5, 1.0), 0.0);
        assert_eq!(ramp_toward_zero(-1.0, 1.0), 0.0);
        assert_eq!(ramp_toward_zero(f64::NAN, 1.0), 0.0);
    }

    #[test]
    fn defaults_valid_bad_values_refused() {
        assert_eq!(SupervisorConfig::DEFAULT.validate(), Ok(()));
        assert_eq!(SupervisorConfig::DEFAULT.hold_samples(1.0), 60);
        let bad = SupervisorConfig {
            hold_time_s: -1.0,
            ..SupervisorConfig::DEFAULT
        };
        assert_eq!(bad.validate(), Err(ConfigError::HoldTime));
        let bad = SupervisorConfig {
            ramp_um_per_s: f64::NAN,
            ..SupervisorConfig::DEFAULT
        };
        assert_eq!(bad.validate(), Err(ConfigError::RampRate));
        let bad = SupervisorConfig {
            recover_time_s: f64::INFINITY,
            ..SupervisorConfig::DEFAULT
        };
        assert_eq!(bad.validate(), Err(ConfigError::RecoverTime));
        assert_eq!(SupervisorConfig::DEFAULT.recover_samples(1.0), 10);
        let bad = SupervisorConfig {
            flap_window_s: -1.0,
            ..SupervisorConfig::DEFAULT
        };
        assert_eq!(bad.validate(), Err(ConfigError::FlapWindow));
    }
}
