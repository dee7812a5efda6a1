//! Filter-bank regression ("fbank"): a regularised linear regression over
//! first-order low-pass filtered inputs.
//!
//! The structure is the parallel form of a transfer-function bank with fixed
//! real poles: seed 004 Eq. 1-2 (`dZ = sum_i eps_i(dT_i)`, one SISO TF per
//! input) with every TF split into first-order sections
//! `(1 - p) / (1 - p q)` whose poles are chosen in advance (one per time
//! constant `tau_s`) and whose gains are the regression coefficients. Fixing
//! the poles makes the fit linear (a ridge regression in the trainer) while
//! keeping the lag of a thermal response.
//!
//! ## What the hub computes
//!
//! For every [`Feature`] `j`:
//!
//! - `x` is the input channel's reference-adjusted value (the model's
//!   [`Reference`](crate::model::Reference): absolute, the run's first
//!   sample, or a fixed value), exactly as every other kind sees it;
//! - `v = x^power`, with `power` 1 or 2 (anything else is refused);
//! - if `tau_s == 0` the feature is `s_j = v`;
//! - otherwise `s_j` is a first-order low-pass of `v` with pole
//!   `p = exp(-dt_s / tau_s)`, computed once when the model is validated: on
//!   the first step of a run `s_j = v` (the machine starts in steady state,
//!   as the TF path assumes), after that `s_j = p s_j + (1 - p) v`. The
//!   filter has unit steady-state gain, so a coefficient is the feature's
//!   gain in output units per input unit (per unit squared for `power` 2).
//!   A time constant so long that the pole rounds to exactly 1
//!   ([`HOLD_TAU_S`] at any sample time) holds the run's first value, `s_j = v(0)`: the
//!   trainer uses it to write a regression on changes from the run's first
//!   sample on logged channels (`F(x - x0) = F(x) - x0` for a filter with
//!   unit gain started in steady state).
//!
//! Each [`FbOutput`] is `intercept + sum_j coef[j] s_j`: one coefficient per
//! feature, each model output listed once.
//!
//! Everything is f64, as the TF path: poles of slow thermal lags lie close to
//! z = 1 (tau = 1 h at dt = 1 s gives p = 0.99972), where f32 rounding of
//! `(1 - p) v` integrates into drift (`tf.rs`, "Realisation, and why it is
//! f64"). The coefficients are immutable; the filter memories `s_j` live in
//! the [`ModelState`](crate::model::ModelState), one f64 per feature.

use crate::capacity::{bounded, MAX_OUTPUTS};
use crate::error::ModelError;
use serde::{Deserialize, Serialize};

/// Most features in one filter bank: 32 inputs x 8 (raw, the five time
/// constants of the trainer's grid, a hold and one more), so that `fit --model auto`
/// can average its candidates on a machine with 24 to 32 temperatures and
/// write targets of both input forms on one channel per sensor
/// (host-tools `fit/auto/layout.rs`). It was 128 (32 x 4); the cost on the
/// hub is in docs/firmware-cost.md.
pub const MAX_FB_FEATURES: usize = 256;

/// Time constant of a hold feature: its pole `exp(-dt / f64::MAX)` rounds
/// to exactly 1 at every sample time, so `s = 1 s + 0 v` keeps the run's
/// first value to the last bit (a finite, positive time constant, as
/// [`FilterBank`] requires of every filter).
pub const HOLD_TAU_S: f64 = f64::MAX;

/// One feature: a power of an input, optionally low-pass filtered.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Feature {
    /// Index of the model input channel read.
    pub input: u8,
    /// Power of the reference-adjusted input: 1 or 2.
    pub power: u8,
    /// Time constant of the low-pass filter, s; 0 for the unfiltered value.
    pub tau_s: f64,
}

/// The regression of one model output on the features.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FbOutput {
    /// Index of the model output.
    pub output: u8,
    /// Constant term, in the output's unit.
    pub intercept: f64,
    /// One weight per feature, in feature order.
    #[serde(deserialize_with = "crate::wire::list")]
    pub coef: heapless::Vec<f64, MAX_FB_FEATURES>,
}

/// A filter-bank regression: shared features, one regression per output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilterBank {
    /// The features, each computed once per step for all outputs.
    #[serde(deserialize_with = "crate::wire::list")]
    pub features: heapless::Vec<Feature, MAX_FB_FEATURES>,
    /// The regressions, one per model output.
    #[serde(deserialize_with = "crate::wire::list")]
    pub outputs: heapless::Vec<FbOutput, { MAX_OUTPUTS }>,
}

/// The pole `exp(-dt_s / tau_s)` of a feature's filter (0 when `tau_s` is 0:
/// the update `s = 0 s + 1 v` is then exactly the unfiltered value).
pub fn pole(tau_s: f64, dt_s: f64) -> f64 {
    if tau_s > 0.0 {
        libm::exp(-dt_s / tau_s)
    } else {
        0.0
    }
}

/// What a memory that saw `v0` for `n` steps lacks, per unit of
/// `v1 - v0`, against one that saw the straight line
/// `v0 + (v1 - v0) k / (n + 1)`, `k = 1..=n` (the input lost for `n`
/// steps with `v0` standing in, back at `v1` on step `n + 1`): with
/// `p = exp(-dt_s / tau_s)`, `sum_k (1 - p) p^(n - k) k / (n + 1)`
/// `= (n - p (1 - p^n) / (1 - p)) / (n + 1)`, from 0 (`tau_s` far longer
/// than the loss) to `n / (n + 1)` (no memory). `1 - p` and `1 - p^n`
/// come from `expm1`, so a pole close to 1 does not turn them into
/// rounding; the difference from `n` still cancels, to an absolute error
/// of a few ulps of `n`. 0 for an unfiltered feature (`tau_s` 0) or a
/// loss of nothing; the caller skips holds (a pole of exactly 1).
pub fn line_share(tau_s: f64, dt_s: f64, n: u32) -> f64 {
    let a = dt_s / tau_s;
    if n == 0 || !(tau_s > 0.0 && a > 0.0 && a.is_finite()) {
        return 0.0;
    }
    let n = f64::from(n);
    let p = libm::exp(-a);
    let share = (n + p * libm::expm1(-n * a) / -libm::expm1(-a)) / (n + 1.0);
    share.clamp(0.0, n / (n + 1.0))
}

impl Feature {
    /// `x^power` of the reference-adjusted inputs `x` (0 for a missing
    /// channel, which validation rules out).
    pub fn value(&self, x: &[f64]) -> f64 {
        self.of(x.get(usize::from(self.input)).copied().unwrap_or(0.0))
    }

    /// `u^power` of the feature's input's reference-adjusted value `u`.
    pub fn of(&self, u: f64) -> f64 {
        if self.power == 2 {
            u * u
        } else {
            u
        }
    }
}

/// One filter update: `v` on the first step of a run, else `p s + (1 - p) v`.
pub fn filter_step(pole: f64, s: f64, v: f64, first: bool) -> f64 {
    if first {
        v
    } else {
        pole * s + (1.0 - pole) * v
    }
}

impl FilterBank {
    /// Checks the bank against a model of `n_in` inputs, `n_out` outputs and
    /// sample time `dt_s` (> 0, checked by the caller), and returns the pole
    /// of every feature (in feature order; the rest 0).
    pub fn validate(
        &self,
        n_in: usize,
        n_out: usize,
        dt_s: f64,
    ) -> Result<[f64; MAX_FB_FEATURES], ModelError> {
        let mut poles = [0.0; MAX_FB_FEATURES];
        for (j, (f, p)) in self.features.iter().zip(poles.iter_mut()).enumerate() {
            if usize::from(f.input) >= n_in {
                return Err(ModelError::IndexOutOfRange);
            }
            if !(bounded(f.tau_s) || f.tau_s == HOLD_TAU_S) {
                return Err(ModelError::NonFinite);
            }
            if !(f.power == 1 || f.power == 2) || f.tau_s < 0.0 {
                return Err(ModelError::BadFeature {
                    feature: u8::try_from(j).unwrap_or(u8::MAX),
                });
            }
            *p = pole(f.tau_s, dt_s);
        }
        for (k, eq) in self.outputs.iter().enumerate() {
            if usize::from(eq.output) >= n_out {
                return Err(ModelError::IndexOutOfRange);
            }
            if self.outputs.iter().take(k).any(|o| o.output == eq.output) {
                return Err(ModelError::DuplicateOutput { output: eq.output });
            }
            if eq.coef.len() != self.features.len() {
                return Err(ModelError::ShapeMismatch);
            }
            if !bounded(eq.intercept) || !eq.coef.iter().all(|c| bounded(*c)) {
                return Err(ModelError::NonFinite);
            }
        }
        Ok(poles)
    }

    /// The filter memories after a step with reference-adjusted inputs `x`
    /// from memories `s` (the first step of a run when `first`), passed one
    /// by one to `next(j, s_j)`.
    pub fn advance(
        &self,
        poles: &[f64],
        s: &[f64],
        x: &[f64],
        first: bool,
        mut next: impl FnMut(usize, f64),
    ) {
        for (j, ((f, p), s)) in self.features.iter().zip(poles).zip(s).enumerate() {
            next(j, filter_step(*p, *s, f.value(x), first));
        }
    }

    /// [`FilterBank::advance`] in place: the memories `s` become those after
    /// the step (the same values `advance` passes on, bit for bit).
    pub fn commit(&self, poles: &[f64], s: &mut [f64], x: &[f64], first: bool) {
        for ((f, p), s) in self.features.iter().zip(poles).zip(s.iter_mut()) {
            *s = filter_step(*p, *s, f.value(x), first);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form against the sum it stands for: a memory stepped
    /// through the line and one stepped at `v0`, differenced, for poles
    /// from no memory to a hold and losses of 1 to 5000 steps.
    #[test]
    fn line_share_is_the_memory_the_line_would_have_left() {
        for tau in [0.5, 10.0, 600.0, 3600.0, 1e9] {
            for n in [1u32, 2, 17, 600, 5000] {
                let p = pole(tau, 1.0);
                let (mut line, mut held) = (0.0, 0.0);
                for k in 1..=n {
                    line = filter_step(p, line, f64::from(k) / f64::from(n + 1), false);
                    held = filter_step(p, held, 0.0, false);
                }
                let got = line_share(tau, 1.0, n);
                // The sum rounds once per step: 1e-12 covers 5000 steps.
                assert!(
                    (got - (line - held)).abs() < 1e-12,
                    "tau {tau} n {n}: {got} vs {line}"
                );
            }
        }
        assert_eq!(line_share(0.0, 1.0, 10), 0.0);
        assert_eq!(line_share(HOLD_TAU_S, 1.0, 10), 0.0);
        assert_eq!(line_share(600.0, 1.0, 0), 0.0);
    }

    #[test]
    fn pole_of_an_hour_at_one_second() {
        // exp(-1/3600) = 0.9997222607988971 (Python math.exp), to libm rounding.
        let p = pole(3600.0, 1.0);
        assert!((p - 0.999_722_260_798_897_1).abs() < 1e-15, "{p}");
        assert_eq!(pole(0.0, 1.0), 0.0);
    }

    #[test]
    fn a_pole_of_one_holds_the_first_value_exactly() {
        // exp(-dt / f64::MAX) rounds to 1, and 1 s + 0 v is s to the last bit.
        for dt in [1e-3, 1.0, 40.0, 86_400.0] {
            assert_eq!(pole(HOLD_TAU_S, dt), 1.0);
        }
        let mut s = filter_step(1.0, 0.0, 21.37, true);
        for v in [25.0, -3.0, 1e6, 21.0] {
            s = filter_step(1.0, s, v, false);
        }
        assert_eq!(s, 21.37);
    }

    #[test]
    fn unfiltered_update_is_exact() {
        // p = 0: 0 * s + 1 * v is v to the last bit, whatever s was.
        assert_eq!(filter_step(0.0, 123.456, 0.1, false), 0.1);
        assert_eq!(filter_step(0.9, 123.456, 0.1, true), 0.1);
    }
}
