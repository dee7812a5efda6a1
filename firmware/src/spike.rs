//! Spike rejection for slow signals (temperatures).
//!
//! # Method
//!
//! Thermal signals move slowly: a machine structure warms by a few kelvin
//! over minutes. A reading whose jump from the last *accepted* value exceeds
//!
//! ```text
//! limit_k = max_rate_k_per_s * dt_s + noise_k
//! ```
//!
//! cannot be physics; it is rejected (the pipeline then holds the offsets
//! for that sample), unless the new level persists: when `persist_samples`
//! consecutive readings agree with each other (each within `limit_k` of the
//! previous one) but not with the old level, the last of them is accepted as
//! a real step (a sensor re-seated, a coolant switch-over) and becomes the
//! new reference. A persistence rule (a "confirmation count") rather than a
//! median filter keeps good readings undelayed and costs two floats per
//! channel.
//!
//! Seed 002's table (sampled every ~30 s) shows why: the displacement
//! channels S1/S2 jump to -2.11 mm / +5.29 mm for one sample (9:05:56) and
//! for two in a row (9:08:28, 9:08:56) and come straight back, while its
//! temperatures move by at most ~1.8 K per sample (T9, 9:05:28).
//!
//! A sample without a reading (fault, stale) leaves the reference as it was
//! and breaks a run of agreeing readings: "consecutive" means consecutive
//! samples. The limit does not widen with the gap, so after a long fault a
//! moved temperature is accepted after `persist_samples` samples, not at
//! once (conservative: a few seconds' delay against minute-scale physics).
//!
//! Coefficients ([`SpikeConfig`]) are apart from state ([`SpikeState`]), as
//! in quartiq/idsp: one validated config serves every channel.

use crate::config::{non_negative, positive, ConfigError};

/// Spike-filter settings (temperatures in K, times in s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpikeConfig {
    /// Fastest physical change of a measured temperature, K/s.
    pub max_rate_k_per_s: f64,
    /// Allowance for measurement noise on top of the physical change, K.
    pub noise_k: f64,
    /// Consecutive agreeing samples at a new level that make it a real step
    /// (1: every reading is accepted, the filter is off).
    pub persist_samples: u8,
}

impl SpikeConfig {
    /// The defaults, with their reasons:
    ///
    /// * `max_rate_k_per_s = 0.5` (30 K/min): about 8x the fastest rise in
    ///   seed 002's table (T9, +1.84 K in ~30 s = 0.06 K/s, spindle start-up)
    ///   so no real thermal change is ever rejected.
    /// * `noise_k = 0.5`: seed 002's sample-to-sample scatter is a few
    ///   tenths of a kelvin (T1 13.52 -> 13.10 -> 12.68); the MAX31865's
    ///   PT100 resolution is 0.03 K, so converter noise is far below this.
    /// * `persist_samples = 3`: seed 002 has spikes one and two samples long;
    ///   three agreeing samples (3 s at 1 Hz) are no glitch, and delaying a
    ///   real step by two samples is nothing against minutes of time constant.
    pub const DEFAULT: Self = Self {
        max_rate_k_per_s: 0.5,
        noise_k: 0.5,
        persist_samples: 3,
    };

    /// Checks the settings once; [`SpikeConfig::filter`] then cannot fail.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !positive(self.max_rate_k_per_s) {
            return Err(ConfigError::SpikeRate);
        }
        if !non_negative(self.noise_k) {
            return Err(ConfigError::SpikeNoise);
        }
        if self.persist_samples == 0 {
            return Err(ConfigError::SpikePersist);
        }
        Ok(())
    }

    /// Largest accepted jump between two samples `dt_s` apart, K.
    pub fn limit_k(&self, dt_s: f64) -> f64 {
        self.max_rate_k_per_s * dt_s + self.noise_k
    }

    /// Filters one finite reading `value` of a channel: accepts it (and
    /// makes it the new reference) or rejects it as a spike.
    ///
    /// `limit_k` is [`SpikeConfig::limit_k`] for the sample period
    /// (computed once per period, not per call). A non-finite `value` is
    /// rejected and leaves the state as a missed sample would.
    pub fn filter(&self, state: &mut SpikeState, value: f64, limit_k: f64) -> SpikeVerdict {
        if !value.is_finite() {
            state.miss();
            return SpikeVerdict::Rejected;
        }
        let Some(last) = state.last else {
            // First reading of the channel: nothing to compare with.
            state.accept(value);
            return SpikeVerdict::Accepted;
        };
        if (value - last).abs() <= limit_k {
            state.accept(value);
            return SpikeVerdict::Accepted;
        }
        // A jump: does it continue a run at a new level?
        let run = match state.candidate {
            Some(previous) if (value - previous).abs() <= limit_k => state.run.saturating_add(1),
            _ => 1,
        };
        if run >= self.persist_samples {
            state.accept(value);
            SpikeVerdict::Step
        } else {
            state.candidate = Some(value);
            state.run = run;
            SpikeVerdict::Rejected
        }
    }
}

impl Default for SpikeConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What the filter made of a reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpikeVerdict {
    /// Within the limit of the last accepted value (or the first reading).
    Accepted,
    /// A jump that persisted `persist_samples` samples: a real step, accepted.
    Step,
    /// A jump seen fewer than `persist_samples` times: a spike, rejected.
    Rejected,
}

impl SpikeVerdict {
    /// Whether the reading may be used.
    pub fn accepted(self) -> bool {
        !matches!(self, Self::Rejected)
    }
}

/// One channel's filter memory.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpikeState {
    /// Last accepted value (the reference), `None` before the first reading.
    last: Option<f64>,
    /// Last value of the current run of rejected readings at a new level.
    candidate: Option<f64>,
    /// How many consecutive rejected readings agree with `candidate`.
    run: u8,
}

impl SpikeState {
    /// A channel that has not been read yet: its first reading is accepted.
    pub const NEW: Self = Self {
        last: None,
        candidate: None,
        run: 0,
    };

    /// The last accepted value.
    pub fn last(&self) -> Option<f64> {
        self.last
    }

    /// A sample without a reading (fault or stale): the reference stays, a
    /// run of agreeing readings at a new level is broken.
    pub fn miss(&mut self) {
        self.candidate = None;
        self.run = 0;
    }

    fn accept(&mut self, value: f64) {
        self.last = Some(value);
        self.candidate = None;
        self.run = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: SpikeConfig = SpikeConfig::DEFAULT;
    /// 0.5 K/s * 1 s + 0.5 K.
    const LIMIT: f64 = 1.0;

    fn run(state: &mut SpikeState, values: &[f64]) -> [SpikeVerdict; 8] {
        let mut out = [SpikeVerdict::Rejected; 8];
        for (o, v) in out.iter_mut().zip(values) {
            *o = CFG.filter(state, *v, LIMIT);
        }
        out
    }

    #[test]
    fn defaults_are_valid_and_limit_is_rate_times_dt_plus_noise() {
        assert_eq!(CFG.validate(), Ok(()));
        assert_eq!(CFG.limit_k(1.0), 1.0);
        // Seed 002's 30 s period: 0.5 * 30 + 0.5.
        assert_eq!(CFG.limit_k(30.0), 15.5);
    }

    #[test]
    fn bad_settings_are_refused() {
        let bad = |c: SpikeConfig| c.validate().unwrap_err();
        assert_eq!(
            bad(SpikeConfig {
                max_rate_k_per_s: 0.0,
                ..CFG
            }),
            ConfigError::SpikeRate
        );
        assert_eq!(
            bad(SpikeConfig {
                noise_k: f64::NAN,
                ..CFG
            }),
            ConfigError::SpikeNoise
        );
        assert_eq!(
            bad(SpikeConfig {
                persist_samples: 0,
                ..CFG
            }),
            ConfigError::SpikePersist
        );
    }

    #[test]
    fn single_spike_is_rejected_and_reference_kept() {
        use SpikeVerdict::*;
        let mut s = SpikeState::NEW;
        let v = run(&mut s, &[20.0, 20.4, 50.0, 20.6, 21.5]);
        assert_eq!(&v[..5], &[Accepted, Accepted, Rejected, Accepted, Accepted]);
        assert_eq!(s.last(), Some(21.5));
    }

    #[test]
    fn exactly_the_limit_is_accepted_just_above_is_not() {
        let mut s = SpikeState::NEW;
        CFG.filter(&mut s, 20.0, LIMIT);
        assert_eq!(CFG.filter(&mut s, 21.0, LIMIT), SpikeVerdict::Accepted);
        assert_eq!(
            CFG.filter(&mut s, 22.0 + 1e-9, LIMIT),
            SpikeVerdict::Rejected
        );
    }

    #[test]
    fn two_sample_spike_is_rejected_three_sample_step_accepted() {
        use SpikeVerdict::*;
        let mut s = SpikeState::NEW;
        // Seed 002's two-sample spike: both rejected, then back.
        let v = run(&mut s, &[20.0, 35.0, 35.2, 20.1]);
        assert_eq!(&v[..4], &[Accepted, Rejected, Rejected, Accepted]);
        // A real step: third agreeing sample accepted, then followed.
        let v = run(&mut s, &[30.0, 30.3, 30.5, 30.9]);
        assert_eq!(&v[..4], &[Rejected, Rejected, Step, Accepted]);
        assert_eq!(s.last(), Some(30.9));
    }

    #[test]
    fn disagreeing_jumps_restart_the_run() {
        use SpikeVerdict::*;
        let mut s = SpikeState::NEW;
        let v = run(&mut s, &[20.0, 30.0, 40.0, 40.5, 41.0]);
        assert_eq!(&v[..5], &[Accepted, Rejected, Rejected, Rejected, Step]);
    }

    #[test]
    fn a_missed_sample_breaks_the_run() {
        use SpikeVerdict::*;
        let mut s = SpikeState::NEW;
        run(&mut s, &[20.0, 30.0, 30.0]);
        s.miss();
        let v = run(&mut s, &[30.0, 30.0, 30.0]);
        assert_eq!(&v[..3], &[Rejected, Rejected, Step]);
    }

    #[test]
    fn persist_one_turns_the_filter_off_and_nan_is_rejected() {
        let off = SpikeConfig {
            persist_samples: 1,
            ..CFG
        };
        let mut s = SpikeState::NEW;
        off.filter(&mut s, 20.0, LIMIT);
        assert_eq!(off.filter(&mut s, 500.0, LIMIT), SpikeVerdict::Step);
        assert_eq!(off.filter(&mut s, f64::NAN, LIMIT), SpikeVerdict::Rejected);
        assert_eq!(s.last(), Some(500.0));
    }
}
