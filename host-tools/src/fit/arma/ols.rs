//! Ordinary least squares by Householder QR, for the ADF regressions and
//! the Hannan-Rissanen starting values. Never the normal equations: the
//! lagged differences of a slowly varying series are nearly collinear, and
//! forming `X'X` would square their condition number.

use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector};

/// A least-squares fit `y ~ X b`.
#[derive(Clone, Debug)]
pub struct Ols {
    /// Coefficients, one per column of `X`.
    pub beta: Vec<f64>,
    /// Residual sum of squares.
    pub ssr: f64,
    /// Rows.
    pub nobs: usize,
    /// Standard errors `sqrt(s^2 [(X'X)^-1]_ii)`, `s^2 = ssr / (n - k)`,
    /// with `(X'X)^-1 = R^-1 R^-T` from the QR factor.
    pub se: Vec<f64>,
}

impl Ols {
    /// The Gaussian log-likelihood at the least-squares fit (error variance
    /// `ssr / n`), as statsmodels' `OLS.loglike`.
    pub fn llf(&self) -> f64 {
        let n = self.nobs as f64;
        -n / 2.0 * ((2.0 * std::f64::consts::PI).ln() + (self.ssr / n).ln() + 1.0)
    }

    /// `-2 llf + 2 k`, `k` the number of columns (all of full rank here).
    pub fn aic(&self) -> f64 {
        -2.0 * self.llf() + 2.0 * self.beta.len() as f64
    }
}

/// Solves `min |y - X b|` for an `n x k` design given column by column.
/// Fails (rather than returning nonsense) when `X` is rank-deficient to
/// 1e-12 of its largest diagonal of `R`, or `n <= k`.
pub fn fit(columns: &[Vec<f64>], y: &[f64]) -> Result<Ols> {
    let n = y.len();
    let k = columns.len();
    if n <= k {
        bail!("least squares with {k} regressors needs more than {n} rows");
    }
    if columns.iter().any(|c| c.len() != n) {
        bail!("least squares: columns of unequal length");
    }
    let x = DMatrix::from_fn(n, k, |i, j| columns[j][i]);
    let qr = x.clone().qr();
    let r = qr.r();
    let rmax = (0..k).map(|i| r[(i, i)].abs()).fold(0.0, f64::max);
    if !(rmax.is_finite() && rmax > 0.0) || (0..k).any(|i| r[(i, i)].abs() <= 1e-12 * rmax) {
        bail!("least squares: the regressors are collinear (constant or repeated series?)");
    }
    let mut qty = DVector::from_column_slice(y);
    qr.q_tr_mul(&mut qty);
    let top = qty.rows(0, k).into_owned();
    let Some(beta) = r.solve_upper_triangular(&top) else {
        bail!("least squares: singular triangular factor");
    };
    let resid = DVector::from_column_slice(y) - &x * &beta;
    let ssr = resid.norm_squared();
    let Some(rinv) = r.solve_upper_triangular(&DMatrix::identity(k, k)) else {
        bail!("least squares: singular triangular factor");
    };
    let s2 = ssr / (n - k) as f64;
    let se = (0..k)
        .map(|i| (s2 * rinv.row(i).norm_squared()).sqrt())
        .collect();
    Ok(Ols {
        beta: beta.iter().copied().collect(),
        ssr,
        nobs: n,
        se,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_through_points() {
        // y = 1 + 2 x exactly; then one perturbed point gives a known ssr.
        let x: Vec<f64> = (0..6).map(f64::from).collect();
        let mut y: Vec<f64> = x.iter().map(|v| 1.0 + 2.0 * v).collect();
        let f = fit(&[vec![1.0; 6], x.clone()], &y).unwrap();
        assert!((f.beta[0] - 1.0).abs() < 1e-12 && (f.beta[1] - 2.0).abs() < 1e-12);
        assert!(f.ssr < 1e-20);
        y[0] += 1.0;
        let f = fit(&[vec![1.0; 6], x], &y).unwrap();
        // Hand computation: residual vector of e_0 off the line space.
        assert!((f.ssr - (1.0 - (1.0 / 6.0 + 2.5f64.powi(2) / 17.5))).abs() < 1e-12);
    }

    #[test]
    fn collinear_columns_are_refused() {
        let c = vec![1.0; 10];
        assert!(fit(&[c.clone(), c.clone()], &c).is_err());
    }
}
