//! Transfer-function banks (seed 004, Eq. 1-2).
//!
//! The thermal displacement is a sum of SISO discrete transfer functions,
//! each driven by one temperature's deviation from its reference
//! (`dZ = eps_SP(dT_bearing) + eps_amb(dT_amb)`). Each TF is written as the
//! paper prints it (Eq. 1):
//!
//! `b0 y(k) = a0 u(k) + a1 u(k-1) + ... + an u(k-n) - b1 y(k-1) - ... - bm y(k-m)`
//!
//! ## Realisation, and why it is f64
//! The published coefficients are badly conditioned: SP1's denominator sums to
//! 1e-4 (a pole at 0.99856, a steady-state gain of -5 um/K from a ratio of two
//! four-digit sums) and SP2 differences 16.0005 u(k) - 15.9975 u(k-1). In f32
//! (24-bit mantissa) the rounding of these products, integrated by poles that
//! close to z = 1, drifts by far more than the 0.01 um budget over a day (the
//! golden test measures it). The hub samples at about 1 Hz, so the Cortex-M4F
//! can afford soft-float f64 (a few thousand cycles per update); the firmware
//! therefore runs exactly this f64 code.
//!
//! The ambient TF has a pole *and* a zero at z = 1. Run as printed, its
//! recursion carries a marginally stable mode that integrates rounding error
//! for ever. [`RealisedTf::new`] cancels such common factors exactly when the
//! model is validated (synthetic division by `1 - q` or `1 + q`, or by the
//! quadratic of a conjugate pair on the unit circle), leaving a strictly
//! stable direct form. A pole on or outside the unit circle without a
//! cancelling zero is rejected: it would integrate any offset without bound.

use crate::capacity::bounded;
use crate::poly;
use serde::{Deserialize, Serialize};

/// Highest TF order (delays in `a` or `b`); seed 004 needs 3.
pub const MAX_ORDER: usize = 8;
/// Coefficients per polynomial.
pub const MAX_COEFFS: usize = MAX_ORDER + 1;

/// Entries (SISO TFs) in one bank.
pub const MAX_TF_ENTRIES: usize = 16;

/// Relative tolerance for "this root lies on the unit circle" and "this zero
/// cancels that pole": 1e-9 of the coefficients' scale, far below the four to
/// six printed digits of a paper's coefficients and far above f64 rounding.
const UNIT_CIRCLE_TOL: f64 = 1e-9;

/// Distance within which a zero cancels a complex pole on the unit circle
/// (root finding of a multiple root is accurate to ~sqrt(eps) = 1.5e-8).
const CANCEL_TOL: f64 = 1e-6;

/// One SISO TF of a bank, as written in a spec or fitted by the trainer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TfEntry {
    /// Index of the model output this TF adds to.
    pub output: u8,
    /// Index of the model input channel that drives it.
    pub input: u8,
    /// Input weights `a0..an` (seed 004's `a`, um/K and um s^i/K).
    #[serde(deserialize_with = "crate::wire::list")]
    pub a: heapless::Vec<f64, MAX_COEFFS>,
    /// Output weights `b0..bm` (seed 004's `b`; `b0` non-zero).
    #[serde(deserialize_with = "crate::wire::list")]
    pub b: heapless::Vec<f64, MAX_COEFFS>,
}

/// Why a TF cannot be run.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TfError {
    /// `b` is empty or `b0` is zero: Eq. 1 cannot be solved for `y(k)`.
    ZeroLeadingDenominator,
    /// A coefficient is NaN, infinite or beyond
    /// [`crate::capacity::MAX_MAGNITUDE`] in magnitude.
    NonFinite,
    /// More than [`MAX_ORDER`] delays.
    OrderTooHigh,
    /// A pole outside the unit circle: the TF diverges.
    Unstable {
        /// Real part of the pole.
        re: f64,
        /// Imaginary part of the pole.
        im: f64,
    },
    /// A pole on the unit circle without a zero to cancel it: the TF
    /// integrates (or oscillates) without decaying.
    MarginallyStable {
        /// Real part of the pole.
        re: f64,
        /// Imaginary part of the pole.
        im: f64,
    },
    /// The root finder did not settle on the denominator.
    RootsNotFound,
}

impl core::fmt::Display for TfError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::ZeroLeadingDenominator => write!(f, "b0 is zero or b is empty"),
            Self::NonFinite => write!(
                f,
                "a coefficient is not finite or beyond {:e} in magnitude",
                crate::capacity::MAX_MAGNITUDE
            ),
            Self::OrderTooHigh => write!(f, "order above {MAX_ORDER}"),
            Self::Unstable { re, im } => {
                write!(f, "unstable: pole {re}{im:+}i lies outside the unit circle")
            }
            Self::MarginallyStable { re, im } => write!(
                f,
                "pole {re}{im:+}i lies on the unit circle and no zero cancels it"
            ),
            Self::RootsNotFound => write!(f, "the poles could not be computed"),
        }
    }
}

impl core::error::Error for TfError {}

/// A TF ready to run: normalised by `b0`, common unit-circle factors
/// cancelled, strictly stable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RealisedTf {
    num: [f64; MAX_COEFFS],
    den: [f64; MAX_COEFFS],
    n_num: usize,
    n_den: usize,
    /// Number of `(1 - q)`-type factors cancelled at build time.
    cancelled: u8,
    /// The largest pole modulus (0 without poles), < 1.
    radius: f64,
}

impl RealisedTf {
    /// Checks and realises `a / b` (seed 004 Eq. 1 coefficients).
    pub fn new(a: &[f64], b: &[f64]) -> Result<Self, TfError> {
        if a.iter().chain(b).any(|c| !bounded(*c)) {
            return Err(TfError::NonFinite);
        }
        let a = poly::trim(a);
        let b = poly::trim(b);
        let b0 = match b.first() {
            Some(b0) if *b0 != 0.0 => *b0,
            _ => return Err(TfError::ZeroLeadingDenominator),
        };
        if a.len() > MAX_COEFFS || b.len() > MAX_COEFFS {
            return Err(TfError::OrderTooHigh);
        }
        let mut num = [0.0; MAX_COEFFS];
        let mut den = [0.0; MAX_COEFFS];
        for (n, c) in num.iter_mut().zip(a) {
            *n = c / b0;
        }
        for (d, c) in den.iter_mut().zip(b) {
            *d = c / b0;
        }
        let mut tf = Self {
            num,
            den,
            n_num: a.len(),
            n_den: b.len(),
            cancelled: 0,
            radius: 0.0,
        };
        tf.cancel_real_unit_roots();
        // What runs is `a / b0` and `b / b0` after cancellation: a tiny `b0`
        // (1e-290 under an `a` of 1e12) would carry 1e302 past the bound
        // on the stored coefficients.
        if tf.num().iter().chain(tf.den()).any(|c| !bounded(*c)) {
            return Err(TfError::NonFinite);
        }
        tf.check_poles()?;
        Ok(tf)
    }

    fn num(&self) -> &[f64] {
        self.num.get(..self.n_num).unwrap_or(&[])
    }

    fn den(&self) -> &[f64] {
        self.den.get(..self.n_den).unwrap_or(&[])
    }

    /// Cancels common factors `(1 - q)` and `(1 + q)` exactly. These are the
    /// ones published models carry (differenced inputs, an integrator that the
    /// identification put in both polynomials), and their test is exact: the
    /// polynomial's value at `q = +-1` is a plain (alternating) sum.
    fn cancel_real_unit_roots(&mut self) {
        for r in [1.0, -1.0] {
            loop {
                let at = |c: &[f64]| {
                    if r > 0.0 {
                        poly::sum(c)
                    } else {
                        poly::alternating_sum(c)
                    }
                };
                let num_zero = self.n_num > 1
                    && libm::fabs(at(self.num())) <= UNIT_CIRCLE_TOL * poly::abs_sum(self.num());
                let den_zero = self.n_den > 1
                    && libm::fabs(at(self.den())) <= UNIT_CIRCLE_TOL * poly::abs_sum(self.den());
                if !(num_zero && den_zero) {
                    break;
                }
                let (nn, nd) = (self.n_num, self.n_den);
                if let Some(c) = self.num.get_mut(..nn) {
                    poly::deflate_real(c, r);
                }
                if let Some(c) = self.den.get_mut(..nd) {
                    poly::deflate_real(c, r);
                }
                self.n_num -= 1;
                self.n_den -= 1;
                self.cancelled += 1;
            }
        }
    }

    /// Requires every pole strictly inside the unit circle, cancelling
    /// complex pairs on the circle that a zero matches.
    fn check_poles(&mut self) -> Result<(), TfError> {
        // At most MAX_ORDER / 2 pairs can be cancelled; bound the loop.
        for _ in 0..=MAX_ORDER {
            let poles = poly::roots(self.den()).map_err(|_| TfError::RootsNotFound)?;
            let zeros = poly::roots(self.num()).map_err(|_| TfError::RootsNotFound)?;
            let mut cancelled_pair = false;
            for p in poles.as_slice() {
                let m = p.abs();
                if m > 1.0 + UNIT_CIRCLE_TOL.max(CANCEL_TOL) {
                    return Err(TfError::Unstable { re: p.re, im: p.im });
                }
                if m < 1.0 - CANCEL_TOL {
                    continue;
                }
                let matching = zeros
                    .as_slice()
                    .iter()
                    .any(|z| libm::hypot(z.re - p.re, z.im - p.im) < CANCEL_TOL);
                if !matching || libm::fabs(p.im) < CANCEL_TOL || self.n_num < 3 {
                    return Err(TfError::MarginallyStable { re: p.re, im: p.im });
                }
                let (s, q) = (2.0 * p.re, p.re * p.re + p.im * p.im);
                let (nn, nd) = (self.n_num, self.n_den);
                if let Some(c) = self.num.get_mut(..nn) {
                    poly::deflate_quadratic(c, s, q);
                }
                if let Some(c) = self.den.get_mut(..nd) {
                    poly::deflate_quadratic(c, s, q);
                }
                self.n_num -= 2;
                self.n_den -= 2;
                self.cancelled += 2;
                cancelled_pair = true;
                break;
            }
            if !cancelled_pair {
                self.radius = poles.as_slice().iter().map(|p| p.abs()).fold(0.0, f64::max);
                return Ok(());
            }
        }
        Err(TfError::RootsNotFound)
    }

    /// How long the TF remembers its input at sample time `dt_s`, s: the
    /// time constant of its slowest pole (`-dt / ln r` of the largest pole
    /// modulus `r`), and at least its numerator's span (`n dt` for `n + 1`
    /// input weights: an FIR part forgets exactly then); 0 with `dt_s` 0.
    pub fn memory_s(&self, dt_s: f64) -> f64 {
        if dt_s.is_nan() || dt_s <= 0.0 {
            return 0.0;
        }
        let fir = dt_s * self.n_num.saturating_sub(1) as f64;
        if self.radius <= 0.0 {
            return fir;
        }
        (-dt_s / libm::log(self.radius)).max(fir)
    }

    /// Steady-state gain `sum(num) / sum(den)` (output units per input unit),
    /// well defined because every remaining pole is strictly stable.
    pub fn dc_gain(&self) -> f64 {
        poly::sum(self.num()) / poly::sum(self.den())
    }

    /// Numerator after normalisation and cancellation.
    pub fn numerator(&self) -> &[f64] {
        self.num()
    }

    /// Denominator after normalisation and cancellation (`den[0] = 1`).
    pub fn denominator(&self) -> &[f64] {
        self.den()
    }

    /// How many pole/zero pairs were cancelled when realising.
    pub fn cancelled(&self) -> u8 {
        self.cancelled
    }

    /// The state in which input `u0` has been applied for ever (the machine
    /// starts in thermal equilibrium).
    pub fn steady_state(&self, u0: f64) -> TfHistory {
        let y0 = self.dc_gain() * u0;
        TfHistory {
            u: [u0; MAX_COEFFS],
            y: [y0; MAX_COEFFS],
        }
    }

    /// `y(k)` for input `u(k)` given the history, without changing it.
    pub fn output(&self, hist: &TfHistory, u: f64) -> f64 {
        // u(k-i) = hist.u[i - 1]; y(k-j) = hist.y[j - 1].
        let mut y = self.num.first().copied().unwrap_or(0.0) * u;
        for (c, past) in self.num().iter().skip(1).zip(hist.u.iter()) {
            y += c * past;
        }
        for (c, past) in self.den().iter().skip(1).zip(hist.y.iter()) {
            y -= c * past;
        }
        y
    }
}

/// Past inputs and outputs of one TF (direct form I). Kept apart from the
/// coefficients so a model is immutable and one realisation serves any run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TfHistory {
    u: [f64; MAX_COEFFS],
    y: [f64; MAX_COEFFS],
}

impl Default for TfHistory {
    fn default() -> Self {
        Self {
            u: [0.0; MAX_COEFFS],
            y: [0.0; MAX_COEFFS],
        }
    }
}

impl TfHistory {
    /// Shifts in `u(k)` and `y(k)` once the step is committed.
    pub fn push(&mut self, u: f64, y: f64) {
        self.u.copy_within(0..MAX_COEFFS - 1, 1);
        self.y.copy_within(0..MAX_COEFFS - 1, 1);
        self.u[0] = u;
        self.y[0] = y;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ambient_pole_zero_at_one_is_cancelled() {
        // Seed 004 Table 2, eps_amb: -0.0251 (1 - q) / ((1 - q)(1 - 0.9985 q)).
        let tf = RealisedTf::new(&[-0.0251, 0.0251, 0.0], &[1.0, -1.9985, 0.9985]).unwrap();
        assert_eq!(tf.cancelled(), 1);
        assert_eq!(tf.numerator().len(), 1);
        assert_eq!(tf.denominator().len(), 2);
        // -0.0251 / 0.0015, exact to rounding of the deflation (1e-12 relative).
        assert!((tf.dc_gain() - (-0.0251 / 0.0015)).abs() < 1e-10);
    }

    #[test]
    fn integrator_without_zero_is_rejected() {
        let e = RealisedTf::new(&[0.1], &[1.0, -1.0]).unwrap_err();
        assert!(matches!(e, TfError::MarginallyStable { .. }), "{e:?}");
        let e = RealisedTf::new(&[0.1], &[1.0, -1.5]).unwrap_err();
        assert!(matches!(e, TfError::Unstable { re, .. } if (re - 1.5).abs() < 1e-12));
    }

    #[test]
    fn oscillator_on_circle_cancelled_by_matching_zeros() {
        // (1 - q + q^2) has roots e^(+-i pi/3) on the unit circle; times (1 - 0.5 q).
        let den = [1.0, -1.5, 1.5, -0.5];
        let num = [2.0, -2.0, 2.0];
        let tf = RealisedTf::new(&num, &den).unwrap();
        assert_eq!(tf.cancelled(), 2);
        assert!((tf.dc_gain() - 4.0).abs() < 1e-9, "{}", tf.dc_gain());
        let e = RealisedTf::new(&[1.0], &den).unwrap_err();
        assert!(matches!(e, TfError::MarginallyStable { .. }));
    }

    #[test]
    fn bad_denominators() {
        assert_eq!(
            RealisedTf::new(&[1.0], &[0.0, 1.0]).unwrap_err(),
            TfError::ZeroLeadingDenominator
        );
        assert_eq!(
            RealisedTf::new(&[1.0], &[]).unwrap_err(),
            TfError::ZeroLeadingDenominator
        );
        assert_eq!(
            RealisedTf::new(&[f64::NAN], &[1.0]).unwrap_err(),
            TfError::NonFinite
        );
    }

    #[test]
    fn first_order_step_response() {
        // y(k) = 0.5 y(k-1) + 0.5 u(k): unit step reaches 1 - 0.5^(k+1).
        let tf = RealisedTf::new(&[0.5], &[1.0, -0.5]).unwrap();
        let mut h = tf.steady_state(0.0);
        for k in 0..10 {
            let y = tf.output(&h, 1.0);
            assert!((y - (1.0 - 0.5f64.powi(k + 1))).abs() < 1e-15);
            h.push(1.0, y);
        }
    }
}
