//! ARMA forecaster of a thermal-error series (seed 001).
//!
//! Seed 001 standardises each error series (Eq. 8-9), differences it until
//! the ADF test calls it stationary, and fits an ARMA(p, q) by Yule-Walker and
//! AIC. Here `z = (y - mean) / std`, `w = nabla^d z`, and
//! `w(k) = c + sum phi_i w(k-i) + sum theta_j e(k-j) + e(k)`.
//!
//! On the machine the model sees the measured series up to `k - 1` and
//! forecasts `y(k)`; the innovation `e(k)` is what the forecast missed once
//! `y(k)` arrives. It therefore needs a measurement of the error itself (a
//! probe on the machine) or runs free from the start; see docs/models.md for
//! what that does and does not buy in compensation.

use serde::{Deserialize, Serialize};

/// AR or MA order at most.
pub const MAX_ARMA_ORDER: usize = 10;
/// Differencing order at most (ADF rarely asks for more than 2).
pub const MAX_DIFF: usize = 2;
const HIST: usize = MAX_ARMA_ORDER + MAX_DIFF;

/// ARMA(p, q) on the d-times differenced, standardised series.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Arma {
    /// Input channel carrying the observed series.
    pub channel: u8,
    /// Model output receiving the forecast.
    pub output: u8,
    /// Mean used for standardisation (series units).
    pub mean: f64,
    /// Standard deviation used for standardisation (> 0).
    pub std: f64,
    /// Differencing order `d`.
    pub diff: u8,
    /// Constant `c` of the differenced, standardised series.
    pub constant: f64,
    /// AR coefficients `phi_1..phi_p`.
    #[serde(deserialize_with = "crate::wire::list")]
    pub phi: heapless::Vec<f64, MAX_ARMA_ORDER>,
    /// MA coefficients `theta_1..theta_q`.
    #[serde(deserialize_with = "crate::wire::list")]
    pub theta: heapless::Vec<f64, MAX_ARMA_ORDER>,
}

/// What the forecaster remembers between samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmaState {
    /// Standardised observations, newest first.
    z: [f64; HIST],
    /// Innovations of the differenced series, newest first.
    e: [f64; MAX_ARMA_ORDER],
    /// Observations seen (saturating).
    seen: usize,
}

impl Default for ArmaState {
    fn default() -> Self {
        Self {
            z: [0.0; HIST],
            e: [0.0; MAX_ARMA_ORDER],
            seen: 0,
        }
    }
}

impl Arma {
    fn d(&self) -> usize {
        usize::from(self.diff).min(MAX_DIFF)
    }

    /// Observations needed before the ARMA recursion is used (before that the
    /// forecast is the last observation: persistence).
    pub fn warm_up(&self) -> usize {
        self.phi.len() + self.d() + 1
    }

    /// `nabla^d z` at lag `lag` (0 = newest) from a history, newest first.
    fn differenced(&self, z: &[f64; HIST], lag: usize) -> f64 {
        let at = |i: usize| z.get(lag + i).copied().unwrap_or(0.0);
        match self.d() {
            0 => at(0),
            1 => at(0) - at(1),
            _ => at(0) - 2.0 * at(1) + at(2),
        }
    }

    /// Forecast of the standardised `z(k)` from history up to `k - 1`.
    fn forecast_z(&self, st: &ArmaState) -> f64 {
        if st.seen == 0 {
            return 0.0;
        }
        if st.seen < self.warm_up() {
            return st.z[0];
        }
        let mut w = self.constant;
        for (i, phi) in self.phi.iter().enumerate() {
            w += phi * self.differenced(&st.z, i);
        }
        for (j, theta) in self.theta.iter().enumerate() {
            w += theta * st.e.get(j).copied().unwrap_or(0.0);
        }
        // Undo the differencing: z(k) = w(k) + (z(k) - nabla^d z(k)).
        match self.d() {
            0 => w,
            1 => w + st.z[0],
            _ => w + 2.0 * st.z[0] - st.z[1],
        }
    }

    /// The one-step forecast of `y(k)` in series units (`0` before any
    /// observation: runs start with zero thermal error).
    pub fn forecast(&self, st: &ArmaState) -> f64 {
        if st.seen == 0 {
            return 0.0;
        }
        self.mean + self.std * self.forecast_z(st)
    }

    /// Forecast `h >= 1` steps ahead, feeding forecasts back with zero
    /// innovations (the conditional expectation).
    pub fn forecast_ahead(&self, st: &ArmaState, h: usize) -> f64 {
        let mut s = *st;
        let mut y = self.forecast(&s);
        for _ in 1..h.max(1) {
            self.observe(&mut s, y, y);
            y = self.forecast(&s);
        }
        y
    }

    /// Takes in the observation `y(k)`, given the forecast `yhat` made for it.
    pub fn observe(&self, st: &mut ArmaState, y: f64, yhat: f64) {
        let z = (y - self.mean) / self.std;
        let innovation = if st.seen >= self.warm_up() {
            (y - yhat) / self.std
        } else {
            0.0
        };
        st.z.copy_within(0..HIST - 1, 1);
        st.z[0] = z;
        st.e.copy_within(0..MAX_ARMA_ORDER - 1, 1);
        st.e[0] = innovation;
        st.seen = st.seen.saturating_add(1);
    }

    /// Every coefficient is finite and within
    /// [`crate::capacity::MAX_MAGNITUDE`].
    pub fn is_bounded(&self) -> bool {
        [self.mean, self.std, self.constant]
            .iter()
            .chain(&self.phi)
            .chain(&self.theta)
            .all(|c| crate::capacity::bounded(*c))
    }

    /// The model can run for ever: `std` a normal positive number, `d` at
    /// most [`MAX_DIFF`], the AR part stationary (roots of
    /// `1 - phi_1 q - ... - phi_p q^p` strictly inside the unit circle in z)
    /// and the MA part invertible (same for `1 + theta_1 q + ...`): the
    /// innovations are computed recursively through the MA terms, so a
    /// non-invertible MA part would make them grow without bound.
    pub fn is_valid(&self) -> bool {
        fn inside_unit_circle(lead_sign: f64, c: &[f64]) -> bool {
            let mut poly = [0.0; MAX_ARMA_ORDER + 1];
            poly[0] = 1.0;
            for (p, v) in poly.iter_mut().skip(1).zip(c) {
                *p = lead_sign * v;
            }
            let n = c.len() + 1;
            match crate::poly::roots(poly.get(..n).unwrap_or(&[])) {
                Ok(r) => r.as_slice().iter().all(|z| z.abs() < 1.0 - 1e-9),
                Err(_) => false,
            }
        }
        self.is_bounded()
            && self.std.is_normal()
            && self.std > 0.0
            && usize::from(self.diff) <= MAX_DIFF
            && inside_unit_circle(-1.0, &self.phi)
            && inside_unit_circle(1.0, &self.theta)
    }

    /// The state holds only finite numbers (checked before a step commits).
    pub fn state_is_finite(st: &ArmaState) -> bool {
        st.z.iter().chain(&st.e).all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ar1(phi: f64, diff: u8) -> Arma {
        Arma {
            channel: 0,
            output: 0,
            mean: 0.0,
            std: 1.0,
            diff,
            constant: 0.0,
            phi: heapless::Vec::from_slice(&[phi]).unwrap(),
            theta: heapless::Vec::new(),
        }
    }

    #[test]
    fn ar1_forecast_is_phi_times_last() {
        let m = ar1(0.9, 0);
        let mut st = ArmaState::default();
        for y in [1.0, 2.0, 4.0] {
            let f = m.forecast(&st);
            m.observe(&mut st, y, f);
        }
        assert!((m.forecast(&st) - 3.6).abs() < 1e-15);
        // Two steps ahead: phi^2 * 4.
        assert!((m.forecast_ahead(&st, 2) - 0.81 * 4.0).abs() < 1e-14);
    }

    #[test]
    fn differenced_random_walk_with_drift_extrapolates_the_trend() {
        // d = 1, w = c: z(k) = z(k-1) + c. With c = 0.5 and std 2 (series units: +1 per step).
        let mut m = ar1(0.0, 1);
        m.std = 2.0;
        m.constant = 0.5;
        let mut st = ArmaState::default();
        for y in [0.0, 1.0, 2.0, 3.0] {
            let f = m.forecast(&st);
            m.observe(&mut st, y, f);
        }
        assert!((m.forecast(&st) - 4.0).abs() < 1e-15);
    }

    #[test]
    fn ma_term_uses_innovations() {
        // w(k) = e(k) + 0.5 e(k-1): after a surprise of +2 the next forecast is +1.
        let mut m = ar1(0.0, 0);
        m.phi.clear();
        m.theta = heapless::Vec::from_slice(&[0.5]).unwrap();
        let mut st = ArmaState::default();
        let f0 = m.forecast(&st);
        m.observe(&mut st, 0.0, f0);
        let f1 = m.forecast(&st);
        assert_eq!(f1, 0.0);
        m.observe(&mut st, 2.0, f1);
        assert!((m.forecast(&st) - 1.0).abs() < 1e-15);
    }
}
