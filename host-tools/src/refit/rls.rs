//! Recursive least squares with exponential forgetting, started from the
//! old model's coefficients (the update of `refit` for linear and PCR
//! models).
//!
//! Model `y = theta_0 + sum_i theta_i phi_i`. The regressors are centred
//! and scaled (mean and standard deviation over the update rows) so that one
//! prior covariance means the same for every coefficient; the coefficients
//! are mapped into that basis, updated, and mapped back. With forgetting
//! factor `lambda` and prior covariance `P0 = I / n_prior` the recursion
//!
//! ```text
//! e = y - z' theta;  k = P z / (lambda + z' P z);  theta += k e;  P = (P - k z' P) / lambda
//! ```
//!
//! ends at the minimiser of
//! `sum_k lambda^(N-k) e_k^2 + lambda^N n_prior |theta - theta_old|^2`:
//! the old coefficients weigh as much as `n_prior` samples of unit-variance,
//! uncorrelated regressors, and that weight decays like the data's. The
//! unit test checks the recursion against this closed form.

use crate::num::linalg::moments;
use nalgebra::{DMatrix, DVector};

/// Coefficients `(intercept, slopes)` in raw regressor units.
pub type Coefs = (f64, Vec<f64>);

/// The basis the recursion runs in: `z = [1, (phi - mean) / std]`.
struct Basis {
    mean: Vec<f64>,
    std: Vec<f64>,
}

impl Basis {
    fn new(rows: &[Vec<f64>], m: usize) -> Self {
        let (mean, std) = moments(rows, m);
        let std = std
            .into_iter()
            .map(|s| if s > 0.0 { s } else { 1.0 })
            .collect();
        Self { mean, std }
    }

    fn z(&self, phi: &[f64]) -> DVector<f64> {
        let mut z = DVector::from_element(phi.len() + 1, 1.0);
        for (i, v) in phi.iter().enumerate() {
            z[i + 1] = (v - self.mean[i]) / self.std[i];
        }
        z
    }

    fn to_z(&self, (b0, b): &Coefs) -> DVector<f64> {
        let mut t = DVector::zeros(b.len() + 1);
        t[0] = b0 + b.iter().zip(&self.mean).map(|(b, m)| b * m).sum::<f64>();
        for (i, bi) in b.iter().enumerate() {
            t[i + 1] = bi * self.std[i];
        }
        t
    }

    fn raw(&self, t: &DVector<f64>) -> Coefs {
        let b: Vec<f64> = (0..self.mean.len())
            .map(|i| t[i + 1] / self.std[i])
            .collect();
        let b0 = t[0] - b.iter().zip(&self.mean).map(|(b, m)| b * m).sum::<f64>();
        (b0, b)
    }
}

/// Runs the recursion over `rows`/`y` in order from `old`; returns the new
/// coefficients in raw units.
pub fn rls(rows: &[Vec<f64>], y: &[f64], old: &Coefs, lambda: f64, n_prior: f64) -> Coefs {
    let m = old.1.len();
    let basis = Basis::new(rows, m);
    let mut theta = basis.to_z(old);
    let mut p = DMatrix::<f64>::identity(m + 1, m + 1) / n_prior;
    for (phi, yk) in rows.iter().zip(y) {
        let z = basis.z(phi);
        let pz = &p * &z;
        let denom = lambda + z.dot(&pz);
        let k = &pz / denom;
        let e = yk - z.dot(&theta);
        theta += &k * e;
        p -= &k * pz.transpose();
        p /= lambda;
        // Keep P symmetric against rounding.
        p = (&p + p.transpose()) * 0.5;
    }
    basis.raw(&theta)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form the recursion must reach (see the module doc).
    fn batch(rows: &[Vec<f64>], y: &[f64], old: &Coefs, lambda: f64, n_prior: f64) -> Coefs {
        let m = old.1.len();
        let basis = Basis::new(rows, m);
        let n = rows.len() as i32;
        let mut a = DMatrix::<f64>::identity(m + 1, m + 1) * (lambda.powi(n) * n_prior);
        let mut b = &a * basis.to_z(old);
        for (k, (phi, yk)) in rows.iter().zip(y).enumerate() {
            let w = lambda.powi(n - 1 - k as i32);
            let z = basis.z(phi);
            a += &z * z.transpose() * w;
            b += &z * (w * yk);
        }
        basis.raw(&a.lu().solve(&b).unwrap())
    }

    #[test]
    fn recursion_agrees_with_the_closed_form() {
        // 500 samples, two correlated regressors, lambda 0.99: agreement to
        // 1e-8 relative (rounding of 500 rank-one updates).
        let rows: Vec<Vec<f64>> = (0..500)
            .map(|k| {
                let t = f64::from(k);
                vec![
                    20.0 + (t / 40.0).sin(),
                    25.0 + 0.8 * (t / 40.0).sin() + (t / 13.0).cos(),
                ]
            })
            .collect();
        let y: Vec<f64> = rows
            .iter()
            .enumerate()
            .map(|(k, r)| 3.0 + 2.0 * r[0] - r[1] + 0.1 * (k as f64 * 0.7).sin())
            .collect();
        let old = (-1.0, vec![1.5, -0.5]);
        let (r0, r) = rls(&rows, &y, &old, 0.99, 50.0);
        let (b0, b) = batch(&rows, &y, &old, 0.99, 50.0);
        assert!((r0 - b0).abs() < 1e-8 * b0.abs().max(1.0), "{r0} {b0}");
        for (x, z) in r.iter().zip(&b) {
            assert!((x - z).abs() < 1e-8 * z.abs().max(1.0), "{r:?} {b:?}");
        }
    }

    #[test]
    fn no_data_leaves_the_old_coefficients() {
        // With the data exactly on the old plane nothing moves (1e-12).
        let rows: Vec<Vec<f64>> = (0..100).map(|k| vec![f64::from(k % 7), 1.0]).collect();
        let y: Vec<f64> = rows.iter().map(|r| 0.5 + 2.0 * r[0] + 3.0 * r[1]).collect();
        let (b0, b) = rls(&rows, &y, &(0.5, vec![2.0, 3.0]), 0.999, 10.0);
        assert!(
            (b0 - 0.5).abs() < 1e-12 && (b[0] - 2.0).abs() < 1e-12 && (b[1] - 3.0).abs() < 1e-12
        );
    }
}
