//! Dense least squares for the trainers: centred and scaled columns solved
//! by SVD (never the normal equations, whose condition number is the square
//! of the data's: correlated temperature sensors make that fatal).

use super::tsqr::Tsqr;
use anyhow::{bail, Result};
use nalgebra::DMatrix;

/// Column means and standard deviations (sample, n - 1) of row vectors.
pub fn moments(rows: &[Vec<f64>], m: usize) -> (Vec<f64>, Vec<f64>) {
    moments_of(m, &mut |f| rows.iter().for_each(|r| f(r, 0.0))).0
}

/// Rows given by a visitor: `visit(f)` calls `f(x, y)` once per row, the
/// same rows in the same order each time it is called. Lets a tall problem
/// stream from its columns twice instead of being copied into row vectors.
pub type RowVisitor<'a> = dyn FnMut(&mut dyn FnMut(&[f64], f64)) + 'a;

/// Column means and sample standard deviations of the visited `x` (length
/// `m`), and the mean of `y` and the row count.
fn moments_of(m: usize, visit: &mut RowVisitor) -> ((Vec<f64>, Vec<f64>), f64, usize) {
    let mut n = 0usize;
    let mut mean = vec![0.0; m];
    let mut y_sum = 0.0;
    visit(&mut |x, y| {
        n += 1;
        y_sum += y;
        for (acc, v) in mean.iter_mut().zip(x) {
            *acc += v;
        }
    });
    let nf = n as f64;
    mean.iter_mut().for_each(|v| *v /= nf);
    let mut var = vec![0.0; m];
    visit(&mut |x, _| {
        for ((acc, v), mu) in var.iter_mut().zip(x).zip(&mean) {
            *acc += (v - mu) * (v - mu);
        }
    });
    let std = var
        .iter()
        .zip(&mean)
        .map(|(v, mu)| {
            let sd = (v / (nf - 1.0).max(1.0)).sqrt();
            if sd <= ROUNDING * mu.abs() {
                0.0
            } else {
                sd
            }
        })
        .collect();
    ((mean, std), y_sum / nf, n)
}

/// A column whose standard deviation is within this share of its mean is
/// constant to rounding (1000 identical readings of 20.1, summed, give a
/// spread of 6e-14 K, whose inverse weighed the column 1e13 times): its
/// standard deviation is taken as 0, as for exactly equal readings. Any
/// sensor that moves lies many decades above (0.01 K on 20 C is 5e-4).
const ROUNDING: f64 = 1e-10;

/// Standardised design matrix: `(x - mean) / std` per column (a constant
/// column is only centred, giving zeros, which the SVD then ignores).
pub fn standardised(rows: &[Vec<f64>], mean: &[f64], std: &[f64]) -> DMatrix<f64> {
    let m = mean.len();
    DMatrix::from_fn(rows.len(), m, |i, j| {
        (rows[i][j] - mean[j]) / unit_if_zero(std[j])
    })
}

fn unit_if_zero(s: f64) -> f64 {
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

/// Least squares `y ~ b0 + sum b_j x_j` on row vectors `x`. Columns are
/// centred and scaled, solved by SVD with singular values below 1e-10 of the
/// largest treated as zero (the minimum-norm answer for collinear sensors),
/// and mapped back to raw units. Returns `(b0, b)`.
pub fn least_squares(x: &[Vec<f64>], y: &[f64]) -> Result<(f64, Vec<f64>)> {
    if x.len() != y.len() {
        bail!(
            "least squares: {} rows of inputs but {} targets",
            x.len(),
            y.len()
        );
    }
    let m = x.first().map_or(0, Vec::len);
    least_squares_visit(m, &mut |f| x.iter().zip(y).for_each(|(r, &v)| f(r, v)))
}

/// [`least_squares`] over rows streamed by a visitor (two passes: the
/// moments, then a blocked QR of the centred, scaled rows), so a tall
/// problem never holds its rows: the SVD is of the small triangle `R`,
/// which has the design's singular values (`Z = QR`), so the same ones are
/// dropped and the same minimum-norm answer comes out.
pub fn least_squares_visit(m: usize, visit: &mut RowVisitor) -> Result<(f64, Vec<f64>)> {
    let ((mean, std), y_mean, n) = moments_of(m, visit);
    if n <= m {
        bail!("least squares: {n} rows for {m} inputs and an intercept: not enough data");
    }
    let mut qr = Tsqr::new(m);
    let mut z = vec![0.0; m];
    visit(&mut |x, y| {
        for (((zj, v), mu), s) in z.iter_mut().zip(x).zip(&mean).zip(&std) {
            *zj = (v - mu) / unit_if_zero(*s);
        }
        qr.push(&z, y - y_mean);
    });
    let (beta, _) = qr.solve()?;
    let b: Vec<f64> = beta
        .iter()
        .zip(&std)
        .map(|(bz, s)| if *s > 0.0 { bz / s } else { 0.0 })
        .collect();
    let b0 = y_mean - b.iter().zip(&mean).map(|(b, m)| b * m).sum::<f64>();
    Ok((b0, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_readings_have_no_spread() {
        // 1000 readings of 20.1 sum with rounding: the spread was 6e-14
        // and a PCR fit weighed the column by its inverse (beyond 1e12,
        // which model-core refuses). Now exactly 0; a 0.01 K wobble is kept.
        let rows: Vec<Vec<f64>> = (0..1000)
            .map(|i| vec![20.1, 20.1 + 0.01 * f64::from(i % 2)])
            .collect();
        let (mean, std) = moments(&rows, 2);
        assert!((mean[0] - 20.1).abs() < 1e-12);
        assert_eq!(std[0], 0.0);
        // The wobble's sample sd: 0.005 * sqrt(1000 / 999).
        assert!(
            (std[1] - 0.005 * (1000.0f64 / 999.0).sqrt()).abs() < 1e-12,
            "{}",
            std[1]
        );
    }

    #[test]
    fn exact_plane_is_recovered() {
        // y = 1 + 2 x1 - 3 x2, no noise: recovered to rounding (1e-10).
        let x: Vec<Vec<f64>> = (0..20)
            .map(|i| vec![f64::from(i), f64::from((i * 7) % 5)])
            .collect();
        let y: Vec<f64> = x.iter().map(|r| 1.0 + 2.0 * r[0] - 3.0 * r[1]).collect();
        let (b0, b) = least_squares(&x, &y).unwrap();
        assert!(
            (b0 - 1.0).abs() < 1e-10 && (b[0] - 2.0).abs() < 1e-10 && (b[1] + 3.0).abs() < 1e-10
        );
    }

    #[test]
    fn collinear_columns_get_the_minimum_norm_answer() {
        // x2 = x1 exactly: y = 4 x1 splits as 2 + 2 (minimum norm), not 1e15 - 1e15.
        let x: Vec<Vec<f64>> = (0..10).map(|i| vec![f64::from(i), f64::from(i)]).collect();
        let y: Vec<f64> = x.iter().map(|r| 4.0 * r[0]).collect();
        let (b0, b) = least_squares(&x, &y).unwrap();
        assert!(
            (b[0] - 2.0).abs() < 1e-9 && (b[1] - 2.0).abs() < 1e-9 && b0.abs() < 1e-9,
            "{b0} {b:?}"
        );
    }

    #[test]
    fn too_few_rows_is_an_error() {
        assert!(least_squares(&[vec![1.0, 2.0]], &[1.0]).is_err());
    }
}
