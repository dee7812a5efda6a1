//! Augmented Dickey-Fuller unit-root test with a constant, lag length by AIC
//! (seed 001, section 3.1: "the stationarity of the thermal error sequences
//! was determined by the ADF test"). The extracted text of the seed lost the
//! test's equation; it is the standard one (Said and Dickey 1984):
//!
//! ```text
//! dx(t) = a + g x(t-1) + sum_{i=1..L} b_i dx(t-i) + u(t),   stat = g_hat / se(g_hat)
//! ```
//!
//! `H0: g = 0` (unit root). The p-value and critical values are MacKinnon's
//! ([`super::mackinnon`]). The procedure matches statsmodels 0.15.0
//! `adfuller(x, regression="c", autolag="AIC")`:
//!
//! 1. `maxlag = ceil(12 (n/100)^{1/4})`, capped at `n/2 - 2` (integer division).
//! 2. Every `L` in `0..=maxlag` is fitted on the *same* rows, those
//!    available with `maxlag` lags (`n - 1 - maxlag` of them), and the `L`
//!    with the smallest OLS AIC is kept (the smaller `L` on a tie).
//! 3. The chosen `L` is refitted on all rows it allows (`n - 1 - L`); the
//!    statistic, `nobs` and the critical values come from that refit.

use super::{mackinnon, ols};
use anyhow::{bail, Result};
use serde::Serialize;

/// Lag order statsmodels uses when none is given: `ceil(12 (n/100)^{1/4})`
/// (Schwert's rule), before the cap by the sample size.
pub fn default_maxlag(n: usize) -> usize {
    (12.0 * (n as f64 / 100.0).powf(0.25)).ceil() as usize
}

/// The result of one ADF test.
#[derive(Clone, Debug, Serialize)]
pub struct Adf {
    /// The t statistic of `g`.
    pub stat: f64,
    /// MacKinnon (1994) approximate p-value.
    pub pvalue: f64,
    /// Lagged differences kept (by AIC).
    pub usedlag: usize,
    /// Rows of the final regression.
    pub nobs: usize,
    /// The largest lag tried.
    pub maxlag: usize,
    /// MacKinnon (2010) critical values at 1 %, 5 %, 10 %.
    pub crit: [f64; 3],
}

/// Regressors `[1, x(t-1), dx(t-1) .. dx(t-lags)]` and `dx(t)` on the last
/// `rows` rows.
fn design(x: &[f64], dx: &[f64], lags: usize, rows: usize) -> (Vec<Vec<f64>>, Vec<f64>) {
    let start = dx.len() - rows; // index into dx of the first row
    let mut cols = vec![vec![1.0; rows], x[start..start + rows].to_vec()];
    for i in 1..=lags {
        cols.push(dx[start - i..start - i + rows].to_vec());
    }
    (cols, dx[start..].to_vec())
}

/// ADF test of `x` with a constant; `maxlag` None for statsmodels' default.
pub fn adfuller(x: &[f64], maxlag: Option<usize>) -> Result<Adf> {
    let n = x.len();
    if x.iter().any(|v| !v.is_finite()) {
        bail!("ADF: the series has a non-finite value");
    }
    // statsmodels: maxlag <= n // 2 - ntrend - 1 with ntrend = 1.
    let cap = (n / 2).checked_sub(2);
    let maxlag = match (cap, maxlag) {
        (None, _) => bail!("ADF: {n} samples are too few (at least 4)"),
        (Some(c), Some(m)) if m > c => {
            bail!("ADF: --adf-maxlag {m} is too large for {n} samples (at most {c})")
        }
        (Some(_), Some(m)) => m,
        (Some(c), None) => default_maxlag(n).min(c),
    };
    let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    // Common sample for the lag search.
    let rows = dx.len() - maxlag;
    let mut best: Option<(f64, usize)> = None;
    for lags in 0..=maxlag {
        let (cols, y) = design(x, &dx, lags, rows);
        let fit = ols::fit(&cols, &y)?;
        let aic = fit.aic();
        if best.is_none_or(|(b, _)| aic < b) {
            best = Some((aic, lags));
        }
    }
    let usedlag = best.map_or(0, |b| b.1);
    let rows = dx.len() - usedlag;
    let (cols, y) = design(x, &dx, usedlag, rows);
    let fit = ols::fit(&cols, &y)?;
    let stat = fit.beta[1] / fit.se[1];
    if !stat.is_finite() {
        bail!("ADF: the statistic is not finite (a perfectly fitted series?)");
    }
    Ok(Adf {
        stat,
        pvalue: mackinnon::pvalue(stat),
        usedlag,
        nobs: rows,
        maxlag,
        crit: mackinnon::critical_values(rows),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_maxlag_is_schwert() {
        assert_eq!(default_maxlag(100), 12);
        assert_eq!(default_maxlag(600), 19); // 12 * 6^0.25 = 18.78
    }

    #[test]
    fn too_short_is_an_error() {
        assert!(adfuller(&[1.0, 2.0, 3.0], None).is_err());
        assert!(adfuller(&[1.0, f64::NAN, 3.0, 4.0, 5.0], None).is_err());
    }

    #[test]
    fn white_noise_rejects_trend_does_not() {
        // A deterministic pseudo-random sequence: strongly stationary.
        let mut r = crate::num::rng::SplitMix64::new(12345);
        let noise: Vec<f64> = (0..300).map(|_| r.uniform() - 0.5).collect();
        assert!(adfuller(&noise, None).unwrap().pvalue < 0.01);
        let walk: Vec<f64> = noise
            .iter()
            .scan(0.0, |acc, v| {
                *acc += v;
                Some(*acc)
            })
            .collect();
        assert!(adfuller(&walk, None).unwrap().pvalue > 0.05);
    }
}
