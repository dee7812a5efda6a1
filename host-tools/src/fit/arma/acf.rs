//! Sample autocorrelation and partial autocorrelation (seed 001, section
//! 3.2-3.3: ACF and PACF identify the model's pattern; "tailing" in both
//! points to a mixed ARMA). The extraction lost the estimator; it is the
//! usual biased one (divisor `n`, so the autocovariance sequence is
//! positive semi-definite):
//!
//! ```text
//! c(k) = (1/n) sum_{t=k}^{n-1} (x_t - xbar)(x_{t-k} - xbar),   r(k) = c(k) / c(0)
//! ```
//!
//! The PACF `phi_kk` is the last coefficient of the order-`k` Yule-Walker
//! fit on `r`, computed by the Durbin-Levinson recursion
//!
//! ```text
//! phi_kk = (r(k) - sum_{j<k} phi_{k-1,j} r(k-j)) / (1 - sum_{j<k} phi_{k-1,j} r(j))
//! phi_kj = phi_{k-1,j} - phi_kk phi_{k-1,k-j}
//! ```
//!
//! These equal statsmodels 0.15.0 `acf(x, fft=False)` and
//! `pacf(x, method="ldb")` (checked by the golden tests).

/// Autocovariances `c(0..=nlags)` around the mean, divisor `n` (biased) or
/// `n - k` (`adjusted`).
pub fn autocovariance(x: &[f64], nlags: usize, adjusted: bool) -> Vec<f64> {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n.max(1) as f64;
    let d: Vec<f64> = x.iter().map(|v| v - mean).collect();
    (0..=nlags)
        .map(|k| {
            if k >= n {
                return 0.0;
            }
            let s: f64 = d[k..].iter().zip(&d[..n - k]).map(|(a, b)| a * b).sum();
            s / if adjusted { (n - k) as f64 } else { n as f64 }
        })
        .collect()
}

/// Sample autocorrelations `r(0..=nlags)` (`r(0) = 1`).
pub fn acf(x: &[f64], nlags: usize) -> Vec<f64> {
    let c = autocovariance(x, nlags, false);
    let c0 = c[0];
    c.iter().map(|v| v / c0).collect()
}

/// Durbin-Levinson on autocorrelations `r(0..=m)`: returns the partial
/// autocorrelations `phi_kk` for `k = 0..=m` (`phi_00 = 1`) and the order-`m`
/// AR coefficients. Stops (filling with NaN) if a prediction-error variance
/// reaches zero.
pub fn durbin_levinson(r: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let m = r.len().saturating_sub(1);
    let mut pacf = vec![1.0];
    let mut phi: Vec<f64> = Vec::new();
    let mut v = r.first().copied().unwrap_or(1.0);
    for k in 1..=m {
        let num = r[k]
            - phi
                .iter()
                .enumerate()
                .map(|(j, p)| p * r[k - 1 - j])
                .sum::<f64>();
        if v.is_nan() || v <= 0.0 {
            pacf.resize(m + 1, f64::NAN);
            return (pacf, vec![f64::NAN; m]);
        }
        let a = num / v;
        let prev = phi.clone();
        for j in 0..phi.len() {
            phi[j] = prev[j] - a * prev[k - 2 - j];
        }
        phi.push(a);
        v *= 1.0 - a * a;
        pacf.push(a);
    }
    (pacf, phi)
}

/// Sample partial autocorrelations for lags `0..=nlags` (Durbin-Levinson
/// on the biased ACF).
pub fn pacf(x: &[f64], nlags: usize) -> Vec<f64> {
    durbin_levinson(&acf(x, nlags)).0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiny_exact_case() {
        // x = 1,2,3,4: mean 2.5, d = -1.5,-0.5,0.5,1.5; c0 = 5/4, c1 = (-0.75+-0.25+0.75)/4.
        let c = autocovariance(&[1.0, 2.0, 3.0, 4.0], 1, false);
        assert!((c[0] - 1.25).abs() < 1e-15 && (c[1] - 0.3125).abs() < 1e-15);
    }

    #[test]
    fn ar1_pacf_cuts_off() {
        // Exact AR(1) autocorrelations 0.8^k: PACF is 0.8 then zero.
        let r: Vec<f64> = (0..6).map(|k| 0.8f64.powi(k)).collect();
        let (p, phi) = durbin_levinson(&r);
        assert!((p[1] - 0.8).abs() < 1e-15);
        assert!(p[2..].iter().all(|v| v.abs() < 1e-14));
        assert!((phi[0] - 0.8).abs() < 1e-14);
    }
}
