//! Error metrics of a prediction `ŷ` against a measurement `y`, in one pass
//! and without allocating, for the host tools and the firmware alike.
//!
//! # Definitions
//!
//! With residual `r = y − ŷ` over n samples:
//!
//! ```text
//! rmse          = √(Σr² / n)
//! fit_pct       = (1 − ‖r‖₂ / ‖y − ȳ‖₂) · 100   system-identification "fit"
//!                                               (L. Ljung, System Identification,
//!                                               2nd ed., 1999; MATLAB `compare`)
//! r2            = 1 − Σr² / Σ(y − ȳ)²          coefficient of determination
//! eta_pct       = (1 − ‖r‖₂ / ‖y‖₂) · 100      "predictive ability" η
//! dpk           = |max r| + |min r|             peak-to-peak residual (seed 004)
//! reduction_pct = (1 − mean|r| / mean|y|) · 100 share of the error that
//!                                               compensation would remove
//! ```
//!
//! `eta_pct` is printed by the seed papers (Yang et al., Math. Probl. Eng.
//! 2014, 784218, Table 1; seed 000) as "predictive ability", but their formula
//! was lost in text extraction. This module uses the residual norm relative to
//! the norm of the thermal error itself: 100 % for a perfect prediction, 0 %
//! for predicting zero (no compensation). Unlike `fit_pct`, it does not
//! subtract the mean, so a model that only gets the offset right still scores.
//!
//! # Zero denominators
//!
//! When a denominator is exactly zero (`y` constant for `fit_pct`/`r2`, `y`
//! all zero for `eta_pct`/`reduction_pct`), the score is 100 % (or 1 for `r2`)
//! if the residual is zero too, and 0 otherwise: a perfect prediction keeps
//! its perfect score, and no skill is claimed where none can be measured.
//! Every metric returned is finite; NaN is never returned.
//!
//! # Numerics
//!
//! Sums use Neumaier's compensated summation (A. Neumaier, ZAMM 54, 39–51,
//! 1974), so a 1e6-sample run loses no more than a few ulps instead of
//! ~n·ε. Σ(y − ȳ)² is accumulated about a shift K as `Σ(y−K)² − (Σ(y−K))²/n`
//! (Chan, Golub and LeVeque, Am. Stat. 37(3), 1983): the accumulator takes K
//! = the first sample; [`metrics`] makes a first pass for K = ȳ, which turns
//! it into the corrected two-pass algorithm. Both are exact when `y` is
//! constant, which is detected from the extremes rather than from a sum.

use core::fmt;

/// Why metrics could not be computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum MetricsError {
    /// `y` and `yhat` have different lengths.
    LengthMismatch {
        /// Length of `y`.
        y_len: usize,
        /// Length of `yhat`.
        yhat_len: usize,
    },
    /// No samples.
    Empty,
    /// A value was NaN or infinite.
    NonFinite,
    /// Finite inputs whose residuals or squares overflow `f64`, or more
    /// samples than `usize` counts.
    Overflow,
}

impl fmt::Display for MetricsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LengthMismatch { y_len, yhat_len } => {
                write!(
                    f,
                    "measured has {y_len} samples but predicted has {yhat_len}"
                )
            }
            Self::Empty => f.write_str("no samples"),
            Self::NonFinite => f.write_str("a sample is NaN or infinite"),
            Self::Overflow => f.write_str("samples too large: sums overflow f64"),
        }
    }
}

impl core::error::Error for MetricsError {}

/// Error metrics of a prediction; units are those of `y` (µm for
/// displacements) unless the name says otherwise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Metrics {
    /// Number of samples.
    pub n: usize,
    /// Root-mean-square residual.
    pub rmse: f64,
    /// System-identification fit, %: 100 is perfect, 0 is no better than
    /// predicting the mean, negative is worse.
    pub fit_pct: f64,
    /// Coefficient of determination.
    pub r2: f64,
    /// Predictive ability η, %: residual norm relative to the error's own
    /// norm (see the module doc for why this formula).
    pub eta_pct: f64,
    /// Largest |residual|.
    pub max_abs: f64,
    /// Smallest |residual|.
    pub min_abs: f64,
    /// Mean |residual|.
    pub mean_abs: f64,
    /// Mean residual (signed): the bias of the prediction.
    pub mean: f64,
    /// Most negative residual (prediction furthest above the measurement).
    pub residual_min: f64,
    /// Most positive residual (prediction furthest below the measurement).
    pub residual_max: f64,
    /// |max r| + |min r|. Equals the peak-to-peak spread `max − min` when the
    /// residual changes sign, as it does for any unbiased model; larger when
    /// it does not (seed 004's definition, kept as printed).
    pub dpk: f64,
    /// Share of the mean absolute error that compensation would remove, %.
    pub reduction_pct: f64,
}

impl Metrics {
    /// True when every floating-point field is finite.
    fn is_finite(&self) -> bool {
        [
            self.rmse,
            self.fit_pct,
            self.r2,
            self.eta_pct,
            self.max_abs,
            self.min_abs,
            self.mean_abs,
            self.mean,
            self.residual_min,
            self.residual_max,
            self.dpk,
            self.reduction_pct,
        ]
        .iter()
        .all(|v| v.is_finite())
    }
}

/// Metrics of `yhat` against `y`, in two passes over the slices.
pub fn metrics(y: &[f64], yhat: &[f64]) -> Result<Metrics, MetricsError> {
    if y.len() != yhat.len() {
        return Err(MetricsError::LengthMismatch {
            y_len: y.len(),
            yhat_len: yhat.len(),
        });
    }
    if y.is_empty() {
        return Err(MetricsError::Empty);
    }
    // Pass 1: finiteness and ȳ, the best shift for pass 2.
    let mut sum_y = NeumaierSum::ZERO;
    for (&y_i, &yhat_i) in y.iter().zip(yhat) {
        if !(y_i.is_finite() && yhat_i.is_finite()) {
            return Err(MetricsError::NonFinite);
        }
        sum_y.add(y_i);
    }
    let mean_y = sum_y.value() / count_f64(y.len());
    if !mean_y.is_finite() {
        return Err(MetricsError::Overflow);
    }
    let mut acc = MetricsAccumulator::with_shift(mean_y);
    for (&y_i, &yhat_i) in y.iter().zip(yhat) {
        acc.push(y_i, yhat_i)?;
    }
    acc.finish()
}

/// Streams `(y, ŷ)` rows into [`Metrics`] in O(1) memory.
///
/// Agrees with [`metrics`] to rounding (about 1e-14 relative on well-posed
/// data); it differs only in the shift used for Σ(y − ȳ)².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricsAccumulator {
    n: usize,
    /// K in Σ(y−K); set by the first accepted row unless given.
    shift: Option<f64>,
    sum_r: NeumaierSum,
    sum_r_sq: NeumaierSum,
    sum_abs_r: NeumaierSum,
    sum_y_sq: NeumaierSum,
    sum_abs_y: NeumaierSum,
    sum_dy: NeumaierSum,
    sum_dy_sq: NeumaierSum,
    r_min: f64,
    r_max: f64,
    abs_r_min: f64,
    y_min: f64,
    y_max: f64,
}

impl Default for MetricsAccumulator {
    fn default() -> Self {
        Self::new()
    }
}

impl MetricsAccumulator {
    /// An empty accumulator.
    pub const fn new() -> Self {
        Self {
            n: 0,
            shift: None,
            sum_r: NeumaierSum::ZERO,
            sum_r_sq: NeumaierSum::ZERO,
            sum_abs_r: NeumaierSum::ZERO,
            sum_y_sq: NeumaierSum::ZERO,
            sum_abs_y: NeumaierSum::ZERO,
            sum_dy: NeumaierSum::ZERO,
            sum_dy_sq: NeumaierSum::ZERO,
            r_min: f64::INFINITY,
            r_max: f64::NEG_INFINITY,
            abs_r_min: f64::INFINITY,
            y_min: f64::INFINITY,
            y_max: f64::NEG_INFINITY,
        }
    }

    /// An empty accumulator that centres y on `shift` (the batch path uses ȳ).
    const fn with_shift(shift: f64) -> Self {
        let mut acc = Self::new();
        acc.shift = Some(shift);
        acc
    }

    /// Adds one row: measured `y`, predicted `yhat`.
    ///
    /// A row that is rejected (non-finite, or overflowing) leaves the
    /// accumulator unchanged, so the caller may skip it and go on, or stop.
    pub fn push(&mut self, y: f64, yhat: f64) -> Result<(), MetricsError> {
        if !(y.is_finite() && yhat.is_finite()) {
            return Err(MetricsError::NonFinite);
        }
        let n = self.n.checked_add(1).ok_or(MetricsError::Overflow)?;
        let shift = self.shift.unwrap_or(y);
        let r = y - yhat;
        let dy = y - shift;
        if !(r.is_finite() && dy.is_finite()) {
            return Err(MetricsError::Overflow);
        }
        self.n = n;
        self.shift = Some(shift);
        let abs_r = libm::fabs(r);
        self.sum_r.add(r);
        self.sum_r_sq.add(r * r);
        self.sum_abs_r.add(abs_r);
        self.sum_y_sq.add(y * y);
        self.sum_abs_y.add(libm::fabs(y));
        self.sum_dy.add(dy);
        self.sum_dy_sq.add(dy * dy);
        self.r_min = self.r_min.min(r);
        self.r_max = self.r_max.max(r);
        self.abs_r_min = self.abs_r_min.min(abs_r);
        self.y_min = self.y_min.min(y);
        self.y_max = self.y_max.max(y);
        Ok(())
    }

    /// Rows accepted so far.
    pub const fn len(&self) -> usize {
        self.n
    }

    /// True before the first accepted row.
    pub const fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The metrics of the rows so far; the accumulator can keep going.
    pub fn finish(&self) -> Result<Metrics, MetricsError> {
        if self.n == 0 {
            return Err(MetricsError::Empty);
        }
        let n = count_f64(self.n);
        let sse = self.sum_r_sq.value();
        // Constant y is decided exactly from the extremes, not from sums
        // that might leave a rounding residue and turn 0/0 into ±huge.
        let sst = if self.y_min == self.y_max {
            0.0
        } else {
            let s1 = self.sum_dy.value();
            (self.sum_dy_sq.value() - s1 * s1 / n).max(0.0)
        };
        let sum_y_sq = self.sum_y_sq.value();
        let mean_abs_y = self.sum_abs_y.value() / n;
        // A sum that overflowed would turn a score into a meaningless 100 %
        // (finite/∞), so it is an error rather than a number.
        if !(sse.is_finite() && sst.is_finite() && sum_y_sq.is_finite() && mean_abs_y.is_finite()) {
            return Err(MetricsError::Overflow);
        }
        let mean_abs = self.sum_abs_r.value() / n;
        let residual_norm = libm::sqrt(sse);
        let metrics = Metrics {
            n: self.n,
            rmse: libm::sqrt(sse / n),
            fit_pct: 100.0 * skill(residual_norm, libm::sqrt(sst)),
            r2: skill(sse, sst),
            eta_pct: 100.0 * skill(residual_norm, libm::sqrt(sum_y_sq)),
            max_abs: self.r_max.max(-self.r_min),
            min_abs: self.abs_r_min,
            mean_abs,
            mean: self.sum_r.value() / n,
            residual_min: self.r_min,
            residual_max: self.r_max,
            dpk: libm::fabs(self.r_max) + libm::fabs(self.r_min),
            reduction_pct: 100.0 * skill(mean_abs, mean_abs_y),
        };
        if metrics.is_finite() {
            Ok(metrics)
        } else {
            Err(MetricsError::Overflow)
        }
    }
}

/// `1 − residual/reference`, with the zero-reference rule of the module doc.
fn skill(residual: f64, reference: f64) -> f64 {
    if reference > 0.0 {
        1.0 - residual / reference
    } else if residual == 0.0 {
        1.0
    } else {
        0.0
    }
}

/// A sample count as `f64`; exact below 2⁵³ samples, far beyond any run.
fn count_f64(n: usize) -> f64 {
    n as f64
}

/// Neumaier's compensated sum: the running sum plus the low-order bits
/// that each addition rounded away.
#[derive(Debug, Clone, Copy, PartialEq)]
struct NeumaierSum {
    sum: f64,
    compensation: f64,
}

impl NeumaierSum {
    const ZERO: Self = Self {
        sum: 0.0,
        compensation: 0.0,
    };

    fn add(&mut self, x: f64) {
        let t = self.sum + x;
        // Whichever operand is larger keeps its bits; recover the other's.
        if libm::fabs(self.sum) >= libm::fabs(x) {
            self.compensation += (self.sum - t) + x;
        } else {
            self.compensation += (x - t) + self.sum;
        }
        self.sum = t;
    }

    fn value(&self) -> f64 {
        self.sum + self.compensation
    }
}

#[cfg(test)]
mod tests {
    // The tests allocate; the module itself never does.
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    /// |a − b| ≤ rtol·max(|a|, |b|) + atol.
    fn close(a: f64, b: f64, rtol: f64, atol: f64) -> bool {
        (a - b).abs() <= rtol * a.abs().max(b.abs()) + atol
    }

    /// Deterministic pseudo-random stream (SplitMix64) mapped to [−1, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            // 53 random bits → [0, 1) exactly, then [−1, 1).
            let unit = (z >> 11) as f64 / (1u64 << 53) as f64;
            2.0 * unit - 1.0
        }
    }

    fn stream(y: &[f64], yhat: &[f64]) -> Result<Metrics, MetricsError> {
        let mut acc = MetricsAccumulator::new();
        for (&a, &b) in y.iter().zip(yhat) {
            acc.push(a, b)?;
        }
        acc.finish()
    }

    #[test]
    fn tiny_case_by_hand() {
        // r = [0, 0, 0, −1]; ȳ = 2.5; SST = 2.25+0.25+0.25+2.25 = 5;
        // Σy² = 30; mean|y| = 2.5. All values below are exact in binary or
        // one rounding of sqrt away, hence 1e-12 tolerances.
        let m = metrics(&[1.0, 2.0, 3.0, 4.0], &[1.0, 2.0, 3.0, 5.0]);
        let m = m.unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.n, 4);
        assert_eq!(m.rmse, 0.5);
        assert_eq!(m.dpk, 1.0);
        assert_eq!((m.residual_min, m.residual_max), (-1.0, 0.0));
        assert_eq!((m.max_abs, m.min_abs), (1.0, 0.0));
        assert_eq!((m.mean, m.mean_abs), (-0.25, 0.25));
        assert!(close(m.r2, 0.8, 1e-12, 0.0), "{}", m.r2);
        let fit = (1.0 - 1.0 / 5f64.sqrt()) * 100.0; // 55.2786…
        assert!(close(m.fit_pct, fit, 1e-12, 0.0), "{}", m.fit_pct);
        let eta = (1.0 - 1.0 / 30f64.sqrt()) * 100.0; // 81.7426…
        assert!(close(m.eta_pct, eta, 1e-12, 0.0), "{}", m.eta_pct);
        assert!(
            close(m.reduction_pct, 90.0, 1e-12, 0.0),
            "{}",
            m.reduction_pct
        );
    }

    #[test]
    fn dpk_when_the_residual_keeps_its_sign() {
        // r = [2, 5]: seed 004's |max| + |min| = 7, not max − min = 3.
        let m = metrics(&[12.0, 15.0], &[10.0, 10.0]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.dpk, 7.0);
    }

    #[test]
    fn perfect_prediction_scores_full_marks() {
        let y = [3.0, -1.5, 8.25, 0.0, 2.0];
        let m = metrics(&y, &y).unwrap_or_else(|e| panic!("{e}"));
        // Residual is exactly zero, so these are exact.
        assert_eq!(
            (m.fit_pct, m.r2, m.eta_pct, m.reduction_pct),
            (100.0, 1.0, 100.0, 100.0)
        );
        assert_eq!((m.rmse, m.dpk, m.max_abs), (0.0, 0.0, 0.0));
    }

    #[test]
    fn predicting_the_mean_scores_zero() {
        // ȳ = 2.5 is exact, so SSE and SST are the same sum: exact zero.
        let m = metrics(&[1.0, 2.0, 3.0, 4.0], &[2.5; 4]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((m.fit_pct, m.r2), (0.0, 0.0));
    }

    #[test]
    fn constant_y_rule() {
        // y constant: fit and r2 have no reference; 100/1 only if exact.
        let exact = metrics(&[4.0; 3], &[4.0; 3]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((exact.fit_pct, exact.r2), (100.0, 1.0));
        let off = metrics(&[4.0; 3], &[4.5; 3]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((off.fit_pct, off.r2), (0.0, 0.0));
        // eta and reduction still have a reference: (1 − 0.5/4)·100 = 87.5.
        assert_eq!((off.eta_pct, off.reduction_pct), (87.5, 87.5));
        // The mean of [0.1; 3] rounds to 0.1 + 1 ulp; SST must still come
        // out exactly 0 (else fit would be ~ −1e18 %), so the rule applies.
        let tenth = metrics(&[0.1; 3], &[0.2; 3]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((tenth.fit_pct, tenth.r2), (0.0, 0.0));
        // y all zero: eta and reduction have no reference either.
        let zero = metrics(&[0.0; 2], &[1.0, -1.0]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((zero.eta_pct, zero.reduction_pct), (0.0, 0.0));
    }

    #[test]
    fn errors() {
        assert_eq!(
            metrics(&[1.0, 2.0], &[1.0]),
            Err(MetricsError::LengthMismatch {
                y_len: 2,
                yhat_len: 1
            })
        );
        assert_eq!(metrics(&[], &[]), Err(MetricsError::Empty));
        assert_eq!(
            metrics(&[1.0, f64::NAN], &[1.0, 2.0]),
            Err(MetricsError::NonFinite)
        );
        assert_eq!(
            metrics(&[1.0], &[f64::NEG_INFINITY]),
            Err(MetricsError::NonFinite)
        );
        assert_eq!(
            metrics(&[f64::MAX], &[-f64::MAX]),
            Err(MetricsError::Overflow)
        );
        assert_eq!(
            metrics(&[1e200, 1.0], &[1e200, 1.0]),
            Err(MetricsError::Overflow)
        );
        assert_eq!(MetricsAccumulator::new().finish(), Err(MetricsError::Empty));
    }

    #[test]
    fn rejected_row_leaves_the_accumulator_unchanged() {
        let mut acc = MetricsAccumulator::new();
        assert_eq!(acc.push(1.0, 0.5), Ok(()));
        let before = acc;
        assert_eq!(acc.push(f64::NAN, 0.0), Err(MetricsError::NonFinite));
        assert_eq!(acc.push(f64::MAX, -f64::MAX), Err(MetricsError::Overflow));
        assert_eq!(acc, before);
        assert_eq!(acc.len(), 1);
    }

    #[test]
    fn streaming_equals_batch_on_a_long_run() {
        // 1e5 rows of a drifting thermal error (0..40 µm) with noise. The
        // paths differ only in the shift for SST; with compensated sums they
        // were seen to agree bit for bit, and 1e-12 relative is the promise.
        let mut rng = Rng(7);
        let n = 100_000;
        let mut y = std::vec![0.0; n];
        let mut yhat = y.clone();
        for i in 0..n {
            let t = i as f64 / n as f64;
            let truth = 40.0 * (1.0 - (-3.0 * t).exp()) + 0.5 * rng.next();
            y[i] = truth;
            yhat[i] = truth + 1.5 * rng.next() + 0.2;
        }
        let batch = metrics(&y, &yhat).unwrap_or_else(|e| panic!("{e}"));
        let streamed = stream(&y, &yhat).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(batch.n, streamed.n);
        let pairs = [
            (batch.rmse, streamed.rmse),
            (batch.fit_pct, streamed.fit_pct),
            (batch.r2, streamed.r2),
            (batch.eta_pct, streamed.eta_pct),
            (batch.mean_abs, streamed.mean_abs),
            (batch.mean, streamed.mean),
            (batch.reduction_pct, streamed.reduction_pct),
        ];
        for (a, b) in pairs {
            assert!(close(a, b, 1e-12, 0.0), "{a} vs {b}");
        }
        // Extremes come from the same comparisons: identical.
        assert_eq!((batch.max_abs, batch.dpk), (streamed.max_abs, streamed.dpk));
    }

    #[test]
    fn compensated_sum_keeps_a_million_tenths() {
        // Σ of 1e6 × 0.1 summed naively is off by ~1.3e-11 relative; the
        // compensated mean must be 0.1 to within 4 ulps (~1e-16 relative),
        // so this fails if compensation is lost.
        let mut acc = MetricsAccumulator::new();
        for _ in 0..1_000_000 {
            assert_eq!(acc.push(0.1, 0.0), Ok(()));
        }
        let m = acc.finish().unwrap_or_else(|e| panic!("{e}"));
        assert!(close(m.mean, 0.1, 4.0 * f64::EPSILON, 0.0), "{}", m.mean);
        assert!(close(m.rmse, 0.1, 4.0 * f64::EPSILON, 0.0), "{}", m.rmse);
    }

    #[test]
    fn fit_is_unmoved_by_a_large_offset() {
        // Adding 1e6 to y and ŷ leaves r and SST unchanged in exact
        // arithmetic, but rounds each y to ~1e-10, i.e. ~1e-11 relative on
        // SST. An unshifted one-pass Σy² − nȳ² was seen off by 3e-8 here;
        // the shifted sums must hold 1e-9.
        let mut rng = Rng(11);
        let n = 10_000;
        let mut y = std::vec![0.0; n];
        let mut yhat = y.clone();
        for i in 0..n {
            y[i] = 10.0 * rng.next();
            yhat[i] = y[i] + rng.next();
        }
        let base = metrics(&y, &yhat).unwrap_or_else(|e| panic!("{e}"));
        let y_off: Vec<f64> = y.iter().map(|v| v + 1e6).collect();
        let yhat_off: Vec<f64> = yhat.iter().map(|v| v + 1e6).collect();
        for m in [metrics(&y_off, &yhat_off), stream(&y_off, &yhat_off)] {
            let m = m.unwrap_or_else(|e| panic!("{e}"));
            assert!(close(m.r2, base.r2, 1e-9, 0.0), "{} vs {}", m.r2, base.r2);
            assert!(close(m.fit_pct, base.fit_pct, 1e-9, 0.0), "{}", m.fit_pct);
        }
    }

    fn any_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            proptest::num::f64::ANY,
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::MAX),
            Just(0.0),
            -100.0..100.0f64,
        ]
    }

    proptest! {
        #[test]
        fn never_panics_and_ok_is_finite(
            y in proptest::collection::vec(any_f64(), 0..8),
            yhat in proptest::collection::vec(any_f64(), 0..8),
        ) {
            let batch = metrics(&y, &yhat);
            if y.len() != yhat.len() {
                let mismatch = matches!(batch, Err(MetricsError::LengthMismatch { .. }));
                prop_assert!(mismatch);
            }
            if let Ok(m) = batch {
                prop_assert!(m.is_finite());
                // A mean lies between the extremes, up to its own rounding.
                let slack = 4.0 * f64::EPSILON * m.max_abs;
                prop_assert!(m.min_abs <= m.mean_abs + slack && m.mean_abs <= m.max_abs + slack);
                prop_assert!(m.r2 <= 1.0 && m.fit_pct <= 100.0 && m.eta_pct <= 100.0);
                // Extremes do not depend on the summation shift, so where the
                // streamed path also succeeds they match bit for bit. (Near
                // f64::MAX it may overflow where the batch does not: its
                // shift is the first sample rather than the mean.)
                if let Ok(s) = stream(&y, &yhat) {
                    prop_assert_eq!(
                        (s.n, s.residual_min, s.residual_max, s.min_abs, s.dpk),
                        (m.n, m.residual_min, m.residual_max, m.min_abs, m.dpk)
                    );
                }
            }
        }
    }
}
