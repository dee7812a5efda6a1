//! Yule-Walker AR estimates (seed 001, Eq. 17-20: the autoregression
//! coefficients solve `R phi = r` with the estimated autocovariances in
//! place of the theoretical ones). The extracted equations are lost; written
//! out, for order `p` on the demeaned series,
//!
//! ```text
//! [c0      c1   ..  c(p-1)] [phi_1]   [c1]
//! [c1      c0   ..  c(p-2)] [  .  ] = [ .]      sigma^2 = c0 - sum phi_i c(i)
//! [..                   c0] [phi_p]   [cp]
//! ```
//!
//! with `c(k)` divided by `n - k` ([`Method::Adjusted`], statsmodels 0.15.0's
//! default `method="adjusted"`) or by `n` ([`Method::Mle`], which always
//! gives a stationary AR). Matches `statsmodels.regression.linear_model.yule_walker`
//! (demean=True, df=None) to 1e-9. The Toeplitz system is solved by LU, as
//! there: the adjusted autocovariances need not be positive definite.

use super::acf::autocovariance;
use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Divisor of the autocovariances.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// `n - k` (statsmodels' default, "adjusted").
    Adjusted,
    /// `n` (the biased, maximum-likelihood-like estimate).
    Mle,
}

/// Yule-Walker estimate of an AR(p).
#[derive(Clone, Debug, Serialize)]
pub struct YuleWalker {
    /// `phi_1..phi_p`.
    pub phi: Vec<f64>,
    /// Innovation standard deviation `sigma` (NaN if `sigma^2 <= 0`, as statsmodels).
    pub sigma: f64,
}

/// Fits an AR(`order`) to `x` by Yule-Walker.
pub fn yule_walker(x: &[f64], order: usize, method: Method) -> Result<YuleWalker> {
    if x.len() <= order {
        bail!(
            "Yule-Walker AR({order}) needs more than {} samples",
            x.len()
        );
    }
    let c = autocovariance(x, order, method == Method::Adjusted);
    if c[0].is_nan() || c[0] <= 0.0 {
        bail!("Yule-Walker: the series has zero variance");
    }
    if order == 0 {
        return Ok(YuleWalker {
            phi: Vec::new(),
            sigma: c[0].sqrt(),
        });
    }
    let r = DMatrix::from_fn(order, order, |i, j| c[i.abs_diff(j)]);
    let rhs = DVector::from_column_slice(&c[1..]);
    let Some(phi) = r.lu().solve(&rhs) else {
        bail!("Yule-Walker: singular autocovariance matrix");
    };
    let s2 = c[0] - phi.iter().zip(&c[1..]).map(|(a, b)| a * b).sum::<f64>();
    Ok(YuleWalker {
        phi: phi.iter().copied().collect(),
        sigma: if s2 > 0.0 { s2.sqrt() } else { f64::NAN },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_one_is_lag_one_autocorrelation() {
        let x = [1.0, 3.0, 2.0, 5.0, 4.0, 6.0];
        let c = autocovariance(&x, 1, false);
        let yw = yule_walker(&x, 1, Method::Mle).unwrap();
        assert!((yw.phi[0] - c[1] / c[0]).abs() < 1e-15);
        assert!((yw.sigma.powi(2) - (c[0] - c[1] * c[1] / c[0])).abs() < 1e-14);
    }

    #[test]
    fn constant_series_is_refused() {
        assert!(yule_walker(&[2.0; 10], 2, Method::Adjusted).is_err());
    }
}
