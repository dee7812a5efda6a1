//! Least squares by blocked QR (TSQR): rows stream through in blocks, so
//! a tall problem costs one pass and memory for one block, and the small
//! triangle left can be solved again for other penalties without the rows.
//! Shared by the ARX/TF trainers and `mlr` on tall runs.

use anyhow::{anyhow, bail, Result};
use nalgebra::{DMatrix, DVector};

/// Least squares by blocked QR of `[X | y]`: rows are pushed one at a time;
/// every `BLOCK` rows the block is stacked under the current `R` and
/// re-triangularised, so memory stays at `BLOCK x (p + 1)`.
pub struct Tsqr {
    p: usize,
    r: Option<DMatrix<f64>>,
    /// The block's rows column by column: cell `(row, j)` at
    /// `j * BLOCK + row` (nalgebra's order, so a flush copies whole columns).
    buf: Vec<f64>,
    rows: usize,
    total: usize,
}

/// Rows per QR block: large enough to amortise the re-triangularisation of
/// the stacked `R`, small enough to stay in cache (2048 x 52 f64 = 850 kB).
pub(crate) const BLOCK: usize = 2048;

impl Tsqr {
    /// For `p` regressors (the target is the extra last column).
    pub fn new(p: usize) -> Self {
        Self {
            p,
            r: None,
            buf: Vec::new(),
            rows: 0,
            total: 0,
        }
    }

    /// Adds one row: `x` (length p) and target `y`.
    pub fn push(&mut self, x: &[f64], y: f64) {
        self.push_row(x.iter().copied().chain([y]));
        self.total += 1;
    }

    /// Adds the `p + 1` cells of one row of `[X | y]` to the block.
    fn push_row(&mut self, cells: impl Iterator<Item = f64>) {
        if self.buf.is_empty() {
            self.buf.resize(BLOCK * (self.p + 1), 0.0);
        }
        for (column, v) in self.buf.chunks_exact_mut(BLOCK).zip(cells) {
            column[self.rows] = v;
        }
        self.rows += 1;
        if self.rows == BLOCK {
            self.flush();
        }
    }

    pub(crate) fn flush(&mut self) {
        if self.rows == 0 {
            return;
        }
        let c = self.p + 1;
        let above = self.r.as_ref().map_or(0, DMatrix::nrows);
        let mut stacked = DMatrix::zeros(above + self.rows, c);
        if let Some(r) = self.r.take() {
            stacked.rows_mut(0, above).copy_from(&r);
        }
        for (j, column) in self.buf.chunks_exact(BLOCK).enumerate() {
            stacked
                .view_mut((above, j), (self.rows, 1))
                .copy_from_slice(&column[..self.rows]);
        }
        self.r = Some(stacked.qr().r());
        self.rows = 0;
    }

    /// Flushes the rows pushed so far and frees the block's buffer (made
    /// again at the next push): for many problems streamed side by side
    /// ([`super::batch`]), one block's buffer at a time. The rows are
    /// stacked where they would be at the next full block or at the end,
    /// so call it only there.
    pub(crate) fn release(&mut self) {
        self.flush();
        self.buf = Vec::new();
    }

    /// Adds every row `other` has seen, through its `R` (the same
    /// least-squares problem): combines row sets without another pass.
    pub fn absorb(&mut self, other: &Tsqr) {
        let pending = (0..other.rows).map(|i| {
            let row = other.buf.chunks_exact(BLOCK).map(move |column| column[i]);
            row.collect::<Vec<_>>()
        });
        let mut rows: Vec<Vec<f64>> = pending.collect();
        if let Some(r) = &other.r {
            rows.extend(r.row_iter().map(|row| row.iter().copied().collect()));
        }
        for row in rows {
            self.push_row(row.into_iter());
        }
        self.total += other.total;
    }

    /// Rows pushed so far.
    pub fn len(&self) -> usize {
        self.total
    }

    /// Whether no row was pushed.
    pub fn is_empty(&self) -> bool {
        self.total == 0
    }

    /// The triangle `R` (at most p x p) of the regressors and `Q^T y`, for
    /// solvers that add rows of their own (Levenberg-Marquardt); `None`
    /// when no row was pushed.
    pub fn triangle(mut self) -> Option<(DMatrix<f64>, DVector<f64>)> {
        self.flush();
        let p = self.p;
        let r = self.r?;
        let k = r.nrows().min(p);
        let r11 = r.view((0, 0), (k, p)).into_owned();
        let z = DVector::from_iterator(k, (0..k).map(|i| r[(i, p)]));
        Some((r11, z))
    }

    /// The least-squares solution (minimum norm where columns are
    /// collinear: SVD of the column-scaled `R`, singular values below 1e-10
    /// of the largest dropped) and the residual sum of squares.
    pub fn solve(self) -> Result<(Vec<f64>, f64)> {
        self.solve_ridge(0.0)
    }

    /// As [`Tsqr::solve`], minimising `|X theta - y|^2 + lambda |S theta|^2`
    /// with `S` the column norms of `X` (ridge on the column-scaled
    /// coefficients; `lambda = 0` is plain least squares). The residual
    /// sum of squares returned excludes the penalty.
    pub fn solve_ridge(self, lambda: f64) -> Result<(Vec<f64>, f64)> {
        self.finish()?.solve(lambda)
    }

    /// The reduced problem, to be solved for several penalties.
    pub fn finish(mut self) -> Result<Triangle> {
        self.flush();
        let p = self.p;
        if self.total <= p {
            bail!(
                "{} samples for {p} coefficients: not enough data",
                self.total
            );
        }
        let r = self.r.ok_or_else(|| anyhow!("no rows"))?;
        let k = r.nrows().min(p);
        let r11 = r.view((0, 0), (k, p)).into_owned();
        let z = DVector::from_iterator(k, (0..k).map(|i| r[(i, p)]));
        let rss_tail = if r.nrows() > p {
            r[(p, p)].powi(2)
        } else {
            0.0
        };
        Ok(Triangle { r11, z, rss_tail })
    }
}

/// A least-squares problem reduced by QR: `R` of the regressors, `Q^T y`
/// and the residual outside the column space. Solving it again for another
/// ridge penalty costs `O(p^3)`, not another pass over the rows.
pub struct Triangle {
    r11: DMatrix<f64>,
    z: DVector<f64>,
    rss_tail: f64,
}

impl Triangle {
    /// See [`Tsqr::solve_ridge`].
    pub fn solve(&self, lambda: f64) -> Result<(Vec<f64>, f64)> {
        let (r11, z) = (&self.r11, &self.z);
        let (k, p) = r11.shape();
        let scale: Vec<f64> = (0..p)
            .map(|j| {
                let n = r11.column(j).norm();
                if n > 0.0 {
                    n
                } else {
                    1.0
                }
            })
            .collect();
        let sl = lambda.sqrt();
        let (rows, zz) = if lambda > 0.0 {
            (k + p, z.clone().resize_vertically(k + p, 0.0))
        } else {
            (k, z.clone())
        };
        let scaled = DMatrix::from_fn(rows, p, |i, j| {
            if i < k {
                r11[(i, j)] / scale[j]
            } else if i - k == j {
                sl
            } else {
                0.0
            }
        });
        let svd = crate::num::decomp::svd(scaled)?;
        let tol = 1e-10 * svd.singular_values.max();
        let beta = svd
            .solve(&zz, tol)
            .map_err(|e| anyhow!("least squares: SVD failed: {e}"))?;
        let theta: Vec<f64> = beta.iter().zip(&scale).map(|(b, s)| b / s).collect();
        // Residual: the part of y outside the column space (R's last
        // diagonal) plus what dropped singular values leave of z.
        let fitted = r11 * DVector::from_column_slice(&theta);
        let rss = self.rss_tail + (z - fitted).norm_squared();
        Ok((theta, rss))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tsqr_agrees_with_svd_least_squares_across_blocks() {
        // 5000 rows (three blocks), exact y = 2 x0 - 0.5 x1 + 3 x2: recovered
        // to 1e-9 (conditioning of the columns is ~1e2).
        let mut ls = Tsqr::new(3);
        for k in 0..5000 {
            let x = [
                f64::from(k).sin(),
                f64::from(k % 17),
                1.0 + f64::from(k) * 1e-3,
            ];
            ls.push(&x, 2.0 * x[0] - 0.5 * x[1] + 3.0 * x[2]);
        }
        let (b, rss) = ls.solve().unwrap();
        assert!(
            (b[0] - 2.0).abs() < 1e-9 && (b[1] + 0.5).abs() < 1e-9 && (b[2] - 3.0).abs() < 1e-9
        );
        assert!(rss < 1e-12, "{rss}");
    }
}
