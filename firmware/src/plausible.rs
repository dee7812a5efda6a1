//! Plausibility of a temperature: readings that are on the PT100 curve and
//! pass the spike filter, but cannot be a machine tool's structure.
//!
//! # Method
//!
//! The RTD curve (-200..=850 C) and the spike filter catch a broken sensor
//! and a one-off jump, but not a sensor that settles on a wrong value: a
//! converter stuck at 850 C is accepted as a "real step" after the spike
//! filter's persistence count, and a drift just under the spike filter's
//! rate passes every sample. Three checks, each a sensor fault of its own
//! (the channel is faulty: the offsets hold, then ramp, like any fault):
//!
//! * **Window** ([`PlausibilityConfig::min_c`]..=[`PlausibilityConfig::max_c`]):
//!   a reading outside it is refused before the spike filter sees it
//!   (STATUS `Implausible`).
//! * **Rate of change**: each temperature is compared with an anchor taken
//!   every `rate_window_s`; a change of more than
//!   `max_rate_k_per_s * rate_window_s` from it, at any sample of the
//!   window, is a fault (STATUS `RateOfChange`), and the channel stays
//!   faulty until one whole window passes without that (then its anchor is
//!   the reading at the window's end). A drift of 0.4 K/s is caught after
//!   `6 K / 0.4 K/s` = 15 s, a drift just over the limit at the end of its
//!   first window. The window runs on time, not on readings: a sample
//!   without a reading the check could judge (stale, faulty, refused by
//!   an earlier check) ages it as well ([`PlausibleState::idle`]). A
//!   window that ends on such a sample passes its last judged reading on
//!   as the next anchor; a whole window without a judged reading leaves
//!   none, so after an outage of two windows at most the first reading
//!   anchors afresh, as the first reading of the channel did. The check
//!   bounds a *rate*: a sensor back after twenty minutes 10 K higher has
//!   moved 0.5 K/min, which a window's limit measured from the value
//!   before the outage would take for a drift and refuse for up to two
//!   windows. The jump itself is the spike filter's to judge (its
//!   persistence count). A rate fault is cleared only by a whole window
//!   of readings without a hit: a gap neither clears it nor lets a sensor
//!   caught drifting come back unjudged.
//! * **Stuck**: a temperature whose value (hence its raw converter code:
//!   the conversion is a pure function of it) has not changed at all for
//!   `stuck_time_s`, while another temperature input moved by at least
//!   `stuck_others_k` within its last completed window of that length
//!   (STATUS `Stuck`). A frozen code (0.03 K per code on a MAX31865) for
//!   half an hour while the machine around it warms by a kelvin is a dead
//!   converter or a stuck bus buffer, not physics. A quiet code alone is
//!   not enough: a well-shielded PT100 in a steady phase can keep one code
//!   for many minutes (the FL_THERMAL run does), so the others must move;
//!   a machine at rest faults nothing, and with a single temperature input
//!   the check is off.
//!
//! Coefficients ([`PlausibilityConfig`]) are apart from state
//! ([`PlausibleState`]), as the spike filter's.

use crate::config::{non_negative, positive, samples_for, ConfigError};

/// Plausibility settings for temperature inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlausibilityConfig {
    /// Lowest plausible temperature, C.
    pub min_c: f64,
    /// Highest plausible temperature, C.
    pub max_c: f64,
    /// Fastest sustained change of a machine temperature, K/s.
    pub max_rate_k_per_s: f64,
    /// Window over which the rate is judged, s.
    pub rate_window_s: f64,
    /// How long an unchanged value, while another temperature moves, makes
    /// a sensor stuck, s (0: off).
    pub stuck_time_s: f64,
    /// How far another temperature must have moved within a window of
    /// `stuck_time_s` for the frozen one to be stuck, K.
    pub stuck_others_k: f64,
}

impl PlausibilityConfig {
    /// The defaults for a machine tool in a workshop, with their reasons:
    ///
    /// * `min_c = -20`, `max_c = 120`: a machine structure, coolant or
    ///   spindle housing is between a cold hall in winter (~0 C) and a hot
    ///   spindle bearing (~70-80 C); 20 K of margin on either side. Beyond
    ///   it the machine is not one a thermal model was fitted on.
    /// * `max_rate_k_per_s = 0.1` over `rate_window_s = 60` (6 K/min):
    ///   seed 002's fastest rise is 0.06 K/s (T9, +1.84 K in ~30 s at
    ///   spindle start-up); 0.1 K/s sustained for a minute is nearly twice
    ///   that. 0.05 K/s would refuse that real start-up.
    /// * `stuck_time_s = 1800`, `stuck_others_k = 1`: half an hour without
    ///   one code of change (0.03 K) while another input moved by 1 K or
    ///   more: structures coupled to the same machine cannot differ that
    ///   much in behaviour. Ten minutes of one code happen in real logs.
    pub const DEFAULT: Self = Self {
        min_c: -20.0,
        max_c: 120.0,
        max_rate_k_per_s: 0.1,
        rate_window_s: 60.0,
        stuck_time_s: 1800.0,
        stuck_others_k: 1.0,
    };

    /// Checks the settings once.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.min_c.is_finite() && self.max_c.is_finite() && self.min_c < self.max_c) {
            return Err(ConfigError::PlausibleWindow);
        }
        if !positive(self.max_rate_k_per_s) || !positive(self.rate_window_s) {
            return Err(ConfigError::PlausibleRate);
        }
        if !non_negative(self.stuck_time_s) || !non_negative(self.stuck_others_k) {
            return Err(ConfigError::StuckTime);
        }
        Ok(())
    }

    /// Whether `t_c` lies in the plausibility window.
    pub fn in_window(&self, t_c: f64) -> bool {
        (self.min_c..=self.max_c).contains(&t_c)
    }
}

impl Default for PlausibilityConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A [`PlausibilityConfig`] at one sample period.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlausibleSamples {
    /// Samples per rate window (at least 1).
    pub rate_window: u32,
    /// Largest change from the window's anchor, K.
    pub rate_limit_k: f64,
    /// Samples of an unchanged value that make it stuck (0: off).
    pub stuck: u32,
    /// [`PlausibilityConfig::stuck_others_k`].
    pub stuck_others_k: f64,
}

impl PlausibleSamples {
    /// `config` at a sample period of `dt_s`.
    pub fn new(config: &PlausibilityConfig, dt_s: f64) -> Self {
        Self {
            rate_window: samples_for(config.rate_window_s, dt_s).max(1),
            rate_limit_k: config.max_rate_k_per_s * config.rate_window_s,
            stuck: samples_for(config.stuck_time_s, dt_s),
            stuck_others_k: config.stuck_others_k,
        }
    }
}

/// Per-channel memory of the rate and stuck checks. Temperatures are kept
/// as f32 (7 digits: 1e-5 K at 100 C, far below a converter code of
/// 0.03 K, so "unchanged" still means "the same code"), to keep 32 inputs'
/// state small in RAM.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlausibleState {
    /// The window's anchor (NaN: none yet).
    anchor: f32,
    /// Samples since the anchor.
    age: u32,
    /// The limit was exceeded in this window.
    hit: bool,
    /// Faulty for its rate.
    rate_fault: bool,
    /// This window judged a reading; a sample of it had none.
    seen: bool,
    gap: bool,
    /// The last value, and how many samples in a row repeated it.
    last: f32,
    same: u32,
    /// The stuck window's anchor, age and largest excursion, and whether
    /// the last completed window moved by `stuck_others_k`.
    win_anchor: f32,
    win_age: u32,
    win_max: f32,
    moved: bool,
}

impl PlausibleState {
    /// Nothing seen.
    pub const NEW: Self = Self {
        anchor: f32::NAN,
        age: 0,
        hit: false,
        rate_fault: false,
        seen: false,
        gap: false,
        last: f32::NAN,
        same: 0,
        win_anchor: f32::NAN,
        win_age: 0,
        win_max: 0.0,
        moved: false,
    };

    /// Takes one spike-filtered temperature; whether its rate is
    /// implausible (see the module doc).
    pub fn rate_fault(&mut self, t_c: f64, n: &PlausibleSamples) -> bool {
        // Narrowing on purpose (see the type's doc); `as` cannot fail.
        #[allow(clippy::cast_possible_truncation)]
        let t_c = t_c as f32;
        if t_c == self.last {
            self.same = self.same.saturating_add(1);
        } else {
            self.same = 0;
        }
        self.last = t_c;
        if n.stuck > 0 {
            self.stuck_window(t_c, n);
        }
        self.judge_rate(t_c, n)
    }

    /// The stuck check's window of readings: how far this channel moved.
    fn stuck_window(&mut self, t_c: f32, n: &PlausibleSamples) {
        if self.win_anchor.is_nan() {
            self.win_anchor = t_c;
        }
        self.win_max = self.win_max.max((t_c - self.win_anchor).abs());
        self.win_age = self.win_age.saturating_add(1);
        if self.win_age >= n.stuck {
            self.moved = f64::from(self.win_max) >= n.stuck_others_k;
            self.win_anchor = t_c;
            self.win_age = 0;
            self.win_max = 0.0;
        }
    }

    /// The rate window's verdict on a judged reading.
    fn judge_rate(&mut self, t_c: f32, n: &PlausibleSamples) -> bool {
        if self.anchor.is_nan() {
            self.anchor = t_c;
            self.age = 0;
            self.gap = false;
        }
        self.age = self.age.saturating_add(1);
        self.seen = true;
        if f64::from((t_c - self.anchor).abs()) > n.rate_limit_k {
            self.hit = true;
            self.rate_fault = true;
        }
        if self.age >= n.rate_window {
            // Cleared only by a whole window of readings without a hit.
            self.rate_fault = self.hit || (self.rate_fault && self.gap);
            self.close(t_c);
        }
        self.rate_fault
    }

    /// Starts the next window from `anchor`.
    fn close(&mut self, anchor: f32) {
        self.hit = false;
        self.seen = false;
        self.gap = false;
        self.anchor = anchor;
        self.age = 0;
    }

    /// A sample without a reading for [`PlausibleState::rate_fault`] to
    /// judge: the rate window ages all the same. A window that ends here
    /// latches a hit and clears nothing (it was not a whole window of
    /// readings); the next one is anchored on the last reading judged, or,
    /// when this window judged none, on the next reading. The stuck check
    /// counts readings and is left as it was.
    pub fn idle(&mut self, n: &PlausibleSamples) {
        self.age = self.age.saturating_add(1);
        self.gap = true;
        if self.age >= n.rate_window {
            self.rate_fault |= self.hit;
            self.close(if self.seen { self.last } else { f32::NAN });
        }
    }

    /// Whether the value has not changed for `n.stuck` samples (the
    /// caller checks that another input moved: [`PlausibleState::moving`]).
    pub fn unchanged(&self, n: &PlausibleSamples) -> bool {
        n.stuck > 0 && self.same >= n.stuck
    }

    /// Whether this channel moved by `stuck_others_k` within its last
    /// completed stuck window.
    pub fn moving(&self) -> bool {
        self.moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_valid_bad_values_refused() {
        let c = PlausibilityConfig::DEFAULT;
        assert_eq!(c.validate(), Ok(()));
        let n = PlausibleSamples::new(&c, 1.0);
        assert_eq!((n.rate_window, n.rate_limit_k, n.stuck), (60, 6.0, 1800));
        let bad = PlausibilityConfig { min_c: 130.0, ..c };
        assert_eq!(bad.validate(), Err(ConfigError::PlausibleWindow));
        let bad = PlausibilityConfig {
            rate_window_s: 0.0,
            ..c
        };
        assert_eq!(bad.validate(), Err(ConfigError::PlausibleRate));
        let bad = PlausibilityConfig {
            stuck_time_s: f64::NAN,
            ..c
        };
        assert_eq!(bad.validate(), Err(ConfigError::StuckTime));
        assert!(c.in_window(-20.0) && c.in_window(120.0) && !c.in_window(120.1));
    }

    /// 6 K from the anchor faults at once; a whole window without that
    /// clears it.
    #[test]
    fn rate_fault_latches_for_a_window() {
        let n = PlausibleSamples::new(&PlausibilityConfig::DEFAULT, 1.0);
        let mut s = PlausibleState::NEW;
        assert!(!s.rate_fault(20.0, &n));
        // 0.4 K a sample: 20.4, 20.8, ... 26.0 (k = 15) is 6.0 K: not over.
        for k in 1..=15 {
            assert!(!s.rate_fault(20.0 + 0.4 * f64::from(k), &n), "{k}");
        }
        assert!(s.rate_fault(26.4, &n), "6.4 K from the anchor");
        // Stops at 26.4 (sample 16). Sample 59 closes the first window
        // (60 samples from the anchor), which had a hit: still faulty, new
        // anchor 26.4; the next window (60..=119) is clean and its last
        // sample clears the fault.
        for k in 17..=118 {
            assert!(s.rate_fault(26.4, &n), "{k}");
        }
        assert!(!s.rate_fault(26.4, &n));
    }

    /// Samples without a reading age the window: a gap shorter than the
    /// window keeps the anchor (the change is still judged from it); one
    /// unjudged sample that ends a window passes the last reading on as
    /// the anchor; only a whole window without a reading drops it.
    #[test]
    fn the_window_runs_on_time_through_a_gap() {
        let n = PlausibleSamples::new(&PlausibilityConfig::DEFAULT, 1.0);
        let mut short = PlausibleState::NEW;
        assert!(!short.rate_fault(20.0, &n));
        for _ in 0..30 {
            short.idle(&n);
        }
        assert!(short.rate_fault(26.5, &n), "31 s after the anchor: 6.5 K");
        let mut edge = PlausibleState::NEW;
        for _ in 0..59 {
            assert!(!edge.rate_fault(20.0, &n));
        }
        edge.idle(&n);
        assert_eq!(edge.anchor, 20.0, "the window's last reading");
        assert!(
            edge.rate_fault(30.0, &n),
            "a step after one unjudged sample"
        );
        let mut long = PlausibleState::NEW;
        assert!(!long.rate_fault(20.0, &n));
        for _ in 0..59 {
            long.idle(&n);
        }
        assert_eq!(long.anchor, 20.0, "the window had a reading");
        for _ in 0..60 {
            long.idle(&n);
        }
        assert!(long.anchor.is_nan(), "a whole window without one");
        assert!(!long.rate_fault(30.0, &n), "anchored afresh");
        assert!(!long.rate_fault(30.1, &n));
    }

    /// A hit latches through a gap of any length: the latch clears only at
    /// the end of a whole window of readings without a hit.
    #[test]
    fn a_rate_fault_outlasts_a_gap() {
        let n = PlausibleSamples::new(&PlausibilityConfig::DEFAULT, 1.0);
        let mut s = PlausibleState::NEW;
        assert!(!s.rate_fault(20.0, &n));
        assert!(s.rate_fault(27.0, &n));
        // The 58th idle sample closes the first window (the anchor, the
        // hit and 58 gaps: 60 samples); its last reading, 27 C, anchors the
        // next, which is all gap and drops the anchor.
        for _ in 0..58 {
            s.idle(&n);
        }
        assert_eq!((s.rate_fault, s.anchor), (true, 27.0));
        for _ in 0..600 {
            s.idle(&n);
        }
        assert!(s.rate_fault && s.anchor.is_nan());
        // Back at 31 C: anchored afresh but still faulty until the 60th
        // reading of that window.
        for k in 0..59 {
            assert!(s.rate_fault(31.0, &n), "{k}");
        }
        assert!(!s.rate_fault(31.0, &n));
    }

    #[test]
    fn unchanged_counts_repeats_and_moving_needs_a_window_of_motion() {
        let n = PlausibleSamples {
            rate_window: 60,
            rate_limit_k: 6.0,
            stuck: 3,
            stuck_others_k: 1.0,
        };
        let mut s = PlausibleState::NEW;
        for _ in 0..3 {
            s.rate_fault(20.0, &n);
        }
        assert!(!s.unchanged(&n) && !s.moving(), "2 repeats; no motion");
        s.rate_fault(20.0, &n);
        assert!(s.unchanged(&n));
        let mut m = PlausibleState::NEW;
        for t in [20.0, 20.5, 21.0] {
            assert!(!m.moving());
            m.rate_fault(t, &n);
        }
        assert!(m.moving(), "1 K within the window");
    }
}
