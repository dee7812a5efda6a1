//! Streamed least squares: one fit straight from borrowed columns through a
//! blocked QR ([`fit_streamed`], [`solve_streamed`]), and many over shared
//! columns in one walk of the rows ([`solve_batch`]), of which one fit is
//! the batch of one. Many fits: a grid search fits one design per grid point, each the same
//! baseline columns plus a few of its own, on the same rows. Fitted one
//! after the other, every design reads every column of every row again,
//! and on a long run (8 MB a column at 10^6 rows) each read comes from
//! memory, not the cache. Here the rows are walked in blocks of
//! [`BATCH_ROWS`]; every design takes its rows of a block while the block's
//! columns are in the cache, first into its blocked QR (the last block with
//! its ridge rows), then, once the coefficients are known, into its
//! fit-part error.
//!
//! Each design sees exactly the pushes, in the same order, and its error
//! the same sums in the same order, as [`solve_scaled`] of it
//! alone would: the results are the same to the bit.

use super::lsq::{self, live_of, predict_into, solve_triangle};
use super::tsqr::{Tsqr, BLOCK};
use std::ops::Range;

/// [`super::lsq::fit_rows_penalised`] streamed: the rows go through a blocked QR
/// ([`super::tsqr::Tsqr`]) straight from the borrowed columns, so no `n x k` matrix is
/// built (memory for one block, one pass per fit), and the target is
/// `y - fixed` (`fixed`: a part of the prediction whose gain is fixed at
/// one) without a copy. The prediction returned includes `fixed`, and
/// `sse_fit` is of `y` minus it on `rows`. The same scaling, rank
/// tolerance and penalty rows as [`super::lsq::fit_rows_penalised`]; the solutions
/// agree to rounding (the R factor of a blocked QR equals the one of a
/// whole-matrix QR up to the signs of its rows).
pub fn fit_streamed(
    cols: &[&[f64]],
    y: &[f64],
    fixed: Option<&[f64]>,
    rows: std::ops::Range<usize>,
    penalty: &[f64],
) -> Option<lsq::LinearFit> {
    let s = solve_streamed(cols, y, fixed, rows, penalty)?;
    Some(lsq::LinearFit {
        pred: lsq::predict(cols, &s.coef, fixed, y.len()),
        coef: s.coef,
        sse_fit: s.sse_fit,
    })
}

/// A streamed fit without its prediction ([`solve_streamed`]): what a
/// search over many designs compares, the prediction being wanted of the
/// one it keeps only ([`super::lsq::predict`]).
#[derive(Debug, Clone)]
pub struct Solved {
    /// One coefficient per regressor (0 for a dead one).
    pub coef: Vec<f64>,
    /// Sum of squared residuals on the fit rows.
    pub sse_fit: f64,
}

/// [`fit_streamed`] without the prediction: the coefficients and the fit
/// rows' sum of squares, the same to the bit (each row's prediction is
/// summed in the same order, block by block, never stored whole).
pub fn solve_streamed(
    cols: &[&[f64]],
    y: &[f64],
    fixed: Option<&[f64]>,
    rows: std::ops::Range<usize>,
    penalty: &[f64],
) -> Option<Solved> {
    let scales = lsq::column_scales(cols, &rows);
    solve_scaled(cols, &scales, y, fixed, rows, penalty)
}

/// [`solve_streamed`] with the columns' scales on `rows` given
/// ([`super::lsq::column_scales`]: the caller keeps those of the columns many fits
/// share). [`solve_batch`] of one design.
pub fn solve_scaled(
    cols: &[&[f64]],
    scales: &[f64],
    y: &[f64],
    fixed: Option<&[f64]>,
    rows: std::ops::Range<usize>,
    penalty: &[f64],
) -> Option<Solved> {
    let design = Batched {
        cols: cols.to_vec(),
        scales: scales.to_vec(),
        fixed,
        penalty,
    };
    solve_batch(&[design], y, rows).pop().flatten()
}

/// Rows of a block: the block's columns (a baseline's eight and a grid's
/// responses, 16 kB each) stay in a core's cache while every design of
/// the batch takes them. A blocked QR's own block ([`BLOCK`]), so that
/// every design's QR stacks a whole block as it takes it and needs its
/// buffer only then: one design's buffer at a time.
const BATCH_ROWS: usize = BLOCK;

/// One design of a batch: its columns, their scales on the fit rows
/// ([`super::lsq::column_scales`]), a part with its gain fixed at one
/// (taken off the target) and the ridge penalty of each column.
#[derive(Debug, Clone)]
pub struct Batched<'a> {
    /// Regressors, every row.
    pub cols: Vec<&'a [f64]>,
    /// Each regressor's rms on the fit rows.
    pub scales: Vec<f64>,
    /// The fixed part, every row.
    pub fixed: Option<&'a [f64]>,
    /// Ridge penalty per column (missing entries 0).
    pub penalty: &'a [f64],
}

/// Each design fitted to `y` on `rows` as [`solve_scaled`]
/// fits it (`None` where that gives `None`), in one walk of the rows for
/// the blocked QRs and one for the fit-part errors.
pub fn solve_batch(designs: &[Batched], y: &[f64], rows: Range<usize>) -> Vec<Option<Solved>> {
    let lives: Vec<Option<Vec<usize>>> = designs.iter().map(|d| usable(d, y, &rows)).collect();
    let mut qrs: Vec<Option<Tsqr>> = lives
        .iter()
        .map(|l| l.as_ref().map(|l| Tsqr::new(l.len())))
        .collect();
    for block in blocks(rows.clone()) {
        let last = block.end == rows.end;
        for ((d, live), qr) in designs.iter().zip(&lives).zip(&mut qrs) {
            if let (Some(live), Some(qr)) = (live, qr) {
                push_rows(qr, d, live, y, block.clone());
                if last {
                    penalty_rows(qr, d, live);
                }
                qr.release();
            }
        }
    }
    let coefs: Vec<Option<Vec<f64>>> = designs
        .iter()
        .zip(&lives)
        .zip(qrs)
        .map(|((d, live), qr)| coefficients(d, live.as_deref()?, qr?))
        .collect();
    let sse = errors(designs, &coefs, y, rows);
    coefs
        .into_iter()
        .zip(sse)
        .map(|(c, sse_fit)| c.map(|coef| Solved { coef, sse_fit }))
        .collect()
}

/// The live columns of design `d` if it can be fitted on `rows` (lengths
/// agree, at least one live column, no more than there are rows).
fn usable(d: &Batched, y: &[f64], rows: &Range<usize>) -> Option<Vec<usize>> {
    let n = y.len();
    let fits = !rows.is_empty()
        && rows.end <= n
        && d.scales.len() == d.cols.len()
        && d.cols.iter().all(|c| c.len() == n)
        && d.fixed.is_none_or(|f| f.len() == n);
    let live = live_of(&d.scales);
    // No live column: nothing to solve (the dense path's SVD would panic).
    (fits && !live.is_empty() && live.len() <= rows.len()).then_some(live)
}

/// `rows` in consecutive blocks of at most [`BATCH_ROWS`].
fn blocks(rows: Range<usize>) -> impl Iterator<Item = Range<usize>> {
    rows.clone()
        .step_by(BATCH_ROWS)
        .map(move |a| a..(a + BATCH_ROWS).min(rows.end))
}

/// Rows `block` of design `d`'s scaled live columns and its target
/// `y - fixed`, pushed into its blocked QR.
fn push_rows(qr: &mut Tsqr, d: &Batched, live: &[usize], y: &[f64], block: Range<usize>) {
    let mut row = vec![0.0; live.len()];
    for i in block {
        for (x, &j) in row.iter_mut().zip(live) {
            *x = d.cols[j][i] / d.scales[j];
        }
        qr.push(&row, d.fixed.map_or(y[i], |f| y[i] - f[i]));
    }
}

/// After the fit rows, one row `sqrt(penalty_j) / scale_j` per penalised
/// live column of design `d` (target 0).
fn penalty_rows(qr: &mut Tsqr, d: &Batched, live: &[usize]) {
    let lambda = |j: usize| d.penalty.get(j).copied().unwrap_or(0.0).max(0.0);
    let mut row = vec![0.0; live.len()];
    for (k, &j) in live.iter().enumerate() {
        if lambda(j) > 0.0 {
            row.fill(0.0);
            row[k] = lambda(j).sqrt() / d.scales[j];
            qr.push(&row, 0.0);
        }
    }
}

/// The coefficients of design `d` from its QR of the fit rows and the
/// penalty rows: the triangle solved; `None` if that fails or a
/// coefficient is not finite.
fn coefficients(d: &Batched, live: &[usize], qr: Tsqr) -> Option<Vec<f64>> {
    let (r, qtb) = qr.triangle()?;
    let coef = solve_triangle(r, qtb, live, &d.scales)?;
    coef.iter().all(|c| c.is_finite()).then_some(coef)
}

/// Each solved design's `sum (y - prediction)^2` over `rows` (0 for the
/// others), its prediction made a block at a time and summed in row order.
fn errors(
    designs: &[Batched],
    coefs: &[Option<Vec<f64>>],
    y: &[f64],
    rows: Range<usize>,
) -> Vec<f64> {
    let mut sse = vec![0.0; designs.len()];
    let mut q = vec![0.0; BATCH_ROWS.min(rows.len())];
    for block in blocks(rows) {
        let q = &mut q[..block.len()];
        for ((d, coef), e) in designs.iter().zip(coefs).zip(&mut sse) {
            let Some(coef) = coef else { continue };
            predict_into(&d.cols, coef, d.fixed, block.clone(), q);
            for (yi, qi) in y[block.clone()].iter().zip(q.iter()) {
                *e += (yi - qi).powi(2);
            }
        }
    }
    sse
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::num::lsq::{column_scales, lowpass};

    /// A design's columns and fixed part.
    type Set<'a> = (Vec<&'a [f64]>, Option<&'a [f64]>);

    #[test]
    fn a_batch_gives_each_design_the_bits_it_gets_alone() {
        // Designs sharing columns, one with a fixed part, one with a dead
        // column, one that cannot be fitted (too few rows for no live
        // column), on rows in the middle over several blocks: each one's
        // coefficients and error must equal its fit alone bit for bit
        // (the same pushes and sums in the same order).
        let n = 5000;
        let t: Vec<f64> = (0..n).map(|k| 60.0 * k as f64).collect();
        let u: Vec<f64> = (0..n).map(|k| ((k / 97) % 4) as f64).collect();
        let a = lowpass(&t, &u, 3600.0, 0.0);
        let b = lowpass(&t, &u, 5400.0, 0.0);
        let one = vec![1.0; n];
        let zero = vec![0.0; n];
        let y: Vec<f64> = (0..n)
            .map(|k| 0.5 + 2.0 * a[k] - 0.7 * b[k] + 0.01 * ((k * 7919) % 13) as f64)
            .collect();
        let rows = 700..4300;
        let penalty = [0.0, 30.0, 0.0];
        let sets: [Set; 4] = [
            (vec![&one, &a], None),
            (vec![&one, &a, &b], Some(&u)),
            (vec![&one, &zero, &b], None),
            (vec![&zero], None),
        ];
        let designs: Vec<Batched> = sets
            .iter()
            .map(|(cols, fixed)| Batched {
                cols: cols.clone(),
                scales: column_scales(cols, &rows),
                fixed: *fixed,
                penalty: &penalty,
            })
            .collect();
        let batch = solve_batch(&designs, &y, rows.clone());
        assert!(batch[3].is_none());
        for (d, got) in designs.iter().zip(&batch) {
            let alone = solve_scaled(&d.cols, &d.scales, &y, d.fixed, rows.clone(), &penalty);
            let bits = |s: &Option<Solved>| {
                s.as_ref().map(|s| {
                    let mut v: Vec<u64> = s.coef.iter().map(|c| c.to_bits()).collect();
                    v.push(s.sse_fit.to_bits());
                    v
                })
            };
            assert_eq!(bits(got), bits(&alone));
        }
    }
}
