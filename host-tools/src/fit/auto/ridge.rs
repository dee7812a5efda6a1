//! Ridge regression cross-validated from sufficient statistics.
//!
//! Every candidate of `fit --model auto` is a ridge regression over some of
//! a bank's feature columns. Per fold the sums `n`, `Σx`, `Σxxᵀ`, `Σxy`,
//! `Σy`, `Σy²` are accumulated once; a candidate's fit on "every fold but
//! `f`" is the total minus fold `f`, and its squared error on fold `f`
//! follows from fold `f`'s sums alone. So a candidate (feature subset,
//! penalty, intercept or not) costs one small Cholesky per fold and never
//! another pass over the rows.
//!
//! Columns are scaled by their root mean square over the calibration rows
//! before the sums are formed (temperatures near 30 C and squared speeds
//! near 1e8 rpm² would otherwise differ by ten orders of magnitude); the
//! penalty applies to the columns standardised on each training set, as
//! scikit-learn's `RidgeCV` on `StandardScaler` output does, with `alpha =
//! lambda * n`.

use super::folds::{Folds, Scheme};
use nalgebra::{DMatrix, DVector};

/// Sums over a set of rows (one fold, or all of them).
#[derive(Clone, Debug)]
pub struct Sums {
    n: f64,
    sx: DVector<f64>,
    sxx: DMatrix<f64>,
    sxy: DVector<f64>,
    sy: f64,
    syy: f64,
}

impl Sums {
    fn zeros(m: usize) -> Self {
        Self {
            n: 0.0,
            sx: DVector::zeros(m),
            sxx: DMatrix::zeros(m, m),
            sxy: DVector::zeros(m),
            sy: 0.0,
            syy: 0.0,
        }
    }

    fn add(&mut self, x: &DVector<f64>, y: f64) {
        self.n += 1.0;
        self.sx += x;
        self.sxx.ger(1.0, x, x, 1.0);
        self.sxy.axpy(y, x, 1.0);
        self.sy += y;
        self.syy += y * y;
    }

    fn plus(&self, o: &Self) -> Self {
        Self {
            n: self.n + o.n,
            sx: &self.sx + &o.sx,
            sxx: &self.sxx + &o.sxx,
            sxy: &self.sxy + &o.sxy,
            sy: self.sy + o.sy,
            syy: self.syy + o.syy,
        }
    }

    fn minus(&self, o: &Self) -> Self {
        Self {
            n: self.n - o.n,
            sx: &self.sx - &o.sx,
            sxx: &self.sxx - &o.sxx,
            sxy: &self.sxy - &o.sxy,
            sy: self.sy - o.sy,
            syy: self.syy - o.syy,
        }
    }

    /// Rows summed.
    pub fn rows(&self) -> f64 {
        self.n
    }
}

/// The scaled feature columns of the calibration rows, their fold sums
/// and the scale that maps coefficients back to raw units.
pub struct Design {
    /// Root mean square of each raw column (1 where it is 0).
    pub scale: Vec<f64>,
    folds: Vec<Sums>,
    total: Sums,
    scheme: Scheme,
}

/// A fitted candidate, in raw feature units.
#[derive(Clone, Debug, PartialEq)]
pub struct Coefs {
    /// Constant term (0 without intercept).
    pub intercept: f64,
    /// One weight per feature of the subset, in the subset's order.
    pub beta: Vec<f64>,
}

/// Cross-validation result of one candidate.
///
/// Candidates are ranked by `geo`, the geometric mean of the per-fold mean
/// squared errors (the mean of their logarithms): every fold counts alike
/// in relative terms, so one fold whose conditions nothing else resembles
/// (a speed never calibrated, the first hours after a cold start) cannot
/// by itself decide the filters and the penalty, as it does under the
/// pooled mse, where its squared errors dominate the sum. Chosen on the
/// development split (docs/fit.md, "The CV criterion").
#[derive(Clone, Debug)]
pub struct CvScore {
    /// Pooled mean squared error over every held-out fold (reported as
    /// `cv_rmse`).
    pub mse: f64,
    /// Standard error of the mean of the per-fold mean squared errors.
    pub se: f64,
    /// Geometric mean of the per-fold mean squared errors: the ranking
    /// criterion.
    pub geo: f64,
    /// Its standard error (delta method: `geo` times the standard error
    /// of the mean log-mse).
    pub geo_se: f64,
}

impl CvScore {
    /// From each scored fold's `(sum of squared errors, samples)`: the
    /// pooled mse, the geometric mean of the per-fold mses and their
    /// standard errors (`None` without a scored sample).
    pub fn pooled(per_fold: &[(f64, f64)]) -> Option<Self> {
        let (sse, n) = per_fold
            .iter()
            .fold((0.0, 0.0), |(s, m), (e, k)| (s + e, m + k));
        if per_fold.is_empty() || n == 0.0 {
            return None;
        }
        let mses: Vec<f64> = per_fold
            .iter()
            .filter(|(_, k)| *k > 0.0)
            .map(|(e, k)| e / k)
            .collect();
        // A fold scored exactly (mse 0) would make the log -inf: floor it
        // at a relative 1e-12 of the pooled mse.
        let floor = (sse / n * 1e-12).max(f64::MIN_POSITIVE);
        let logs: Vec<f64> = mses.iter().map(|m| m.max(floor).ln()).collect();
        let geo = (logs.iter().sum::<f64>() / logs.len() as f64).exp();
        Some(Self {
            mse: sse / n,
            se: standard_error(&mses),
            geo,
            geo_se: geo * standard_error(&logs),
        })
    }
}

/// Standard error of the mean of `v` (sample standard deviation over
/// `sqrt(len)`; 0 for fewer than two values).
pub fn standard_error(v: &[f64]) -> f64 {
    let k = v.len() as f64;
    if v.len() < 2 {
        return 0.0;
    }
    let mean = v.iter().sum::<f64>() / k;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1.0);
    (var / k).sqrt()
}

impl Design {
    /// Accumulates `cols[j][row]` (raw feature columns) and `y[row]`, row
    /// `row` belonging to fold `folds.of[row]` (`None`: not a calibration
    /// row).
    pub fn new(cols: &[Vec<f64>], y: &[f64], folds: &Folds) -> Self {
        let (fold, n_folds, folds_scheme) = (&folds.of, folds.n, folds.scheme);
        let m = cols.len();
        let used = fold.iter().filter(|f| f.is_some()).count().max(1) as f64;
        let scale: Vec<f64> = cols
            .iter()
            .map(|c| {
                let ss: f64 = c
                    .iter()
                    .zip(fold)
                    .filter(|(_, f)| f.is_some())
                    .map(|(v, _)| v * v)
                    .sum();
                let rms = (ss / used).sqrt();
                if rms > 0.0 && rms.is_finite() {
                    rms
                } else {
                    1.0
                }
            })
            .collect();
        let mut folds = vec![Sums::zeros(m); n_folds];
        let mut x = DVector::zeros(m);
        for (row, f) in fold.iter().enumerate() {
            let Some(f) = *f else { continue };
            for (j, c) in cols.iter().enumerate() {
                x[j] = c[row] / scale[j];
            }
            folds[f].add(&x, y[row]);
        }
        let total = folds.iter().fold(Sums::zeros(m), |t, f| t.plus(f));
        Self {
            scale,
            folds,
            total,
            scheme: folds_scheme,
        }
    }

    /// The sums the model scoring fold `f` is fitted on (`None`: the fold
    /// is not scored, or it has no training rows).
    fn train(&self, f: usize) -> Option<Sums> {
        if !self.scheme.scores(f) {
            return None;
        }
        let sums = match self.scheme {
            Scheme::LeaveOut => self.total.minus(self.folds.get(f)?),
            Scheme::Forward { .. } => self.folds[..f]
                .iter()
                .fold(Sums::zeros(self.total.sx.len()), |t, g| t.plus(g)),
        };
        (sums.n > 0.0).then_some(sums)
    }

    /// Number of folds.
    pub fn n_folds(&self) -> usize {
        self.folds.len()
    }

    /// Cross-validation score of the candidate (features `idx`, penalty
    /// `lambda`, with or without intercept); `None` when a fold's
    /// training system is singular.
    pub fn cv(&self, idx: &[usize], lambda: f64, intercept: bool) -> Option<CvScore> {
        let mut per_fold = Vec::new();
        for (i, f) in self.folds.iter().enumerate() {
            if f.n == 0.0 {
                continue;
            }
            let Some(train) = self.train(i) else {
                continue;
            };
            // A fold whose training set cannot be solved (one row) is
            // skipped, as one with no training rows is; a singular system
            // (no penalty, collinear columns) refuses the candidate.
            if train.n < 2.0 {
                continue;
            }
            let (b0, beta) = solve(&train, idx, lambda, intercept)?;
            per_fold.push((sse_on(f, idx, b0, &beta), f.n));
        }
        CvScore::pooled(&per_fold)
    }

    /// The candidate that scores fold `fold` (`None`: fitted on every
    /// row), in raw feature units; `None` when that fold is not scored.
    pub fn fit(
        &self,
        idx: &[usize],
        lambda: f64,
        intercept: bool,
        fold: Option<usize>,
    ) -> Option<Coefs> {
        let train = match fold {
            Some(f) => self.train(f)?,
            None => self.total.clone(),
        };
        let (b0, beta) = solve(&train, idx, lambda, intercept)?;
        Some(Coefs {
            intercept: b0,
            beta: beta
                .iter()
                .zip(idx)
                .map(|(b, &j)| b / self.scale[j])
                .collect(),
        })
    }
}

/// A column whose standard deviation on a training set is below this
/// share of its root mean square counts as constant there (rounding leaves
/// about 1e-8 of it; a temperature's 0.01 K resolution at 30 C is 3e-4).
const CONSTANT_REL: f64 = 1e-6;

/// Ridge on the standardised columns `idx` of `s`; `(intercept, beta)` in
/// the scaled units of the sums.
fn solve(s: &Sums, idx: &[usize], lambda: f64, intercept: bool) -> Option<(f64, DVector<f64>)> {
    let m = idx.len();
    let n = s.n;
    if n < 2.0 {
        return None;
    }
    let mu = DVector::from_fn(m, |i, _| if intercept { s.sx[idx[i]] / n } else { 0.0 });
    let ybar = if intercept { s.sy / n } else { 0.0 };
    let c = DMatrix::from_fn(m, m, |i, j| s.sxx[(idx[i], idx[j])] - n * mu[i] * mu[j]);
    let r = DVector::from_fn(m, |i, _| s.sxy[idx[i]] - n * mu[i] * ybar);
    // Standard deviation of each column on this training set; a column
    // constant there gets weight 0. Constant is judged against the
    // column's root mean square: `Σx² - n mu²` of a constant column is
    // rounding error, about sqrt(eps) of its size, and a weight fitted to
    // it would be noise that swings wherever the column moves.
    let d: Vec<f64> = (0..m).map(|i| (c[(i, i)].max(0.0) / n).sqrt()).collect();
    let live: Vec<usize> = (0..m)
        .filter(|&i| {
            let rms = (s.sxx[(idx[i], idx[i])].max(0.0) / n).sqrt();
            d[i] > 1e-12 && d[i] > CONSTANT_REL * rms
        })
        .collect();
    let k = live.len();
    let mut a = DMatrix::from_fn(k, k, |p, q| {
        let (i, j) = (live[p], live[q]);
        c[(i, j)] / (d[i] * d[j])
    });
    for p in 0..k {
        a[(p, p)] += lambda * n + 1e-12 * n;
    }
    let rhs = DVector::from_fn(k, |p, _| r[live[p]] / d[live[p]]);
    let w = a.cholesky()?.solve(&rhs);
    let mut beta = DVector::zeros(m);
    for (p, &i) in live.iter().enumerate() {
        beta[i] = w[p] / d[i];
    }
    let b0 = ybar - mu.dot(&beta);
    b0.is_finite().then_some((b0, beta))
}

/// Squared error of `b0 + x·beta` (columns `idx`) over the rows of `s`,
/// from the sums alone.
fn sse_on(s: &Sums, idx: &[usize], b0: f64, beta: &DVector<f64>) -> f64 {
    let m = idx.len();
    let mut bsxx = 0.0;
    for i in 0..m {
        let mut row = 0.0;
        for j in 0..m {
            row += s.sxx[(idx[i], idx[j])] * beta[j];
        }
        bsxx += beta[i] * row;
    }
    let bsxy: f64 = (0..m).map(|i| beta[i] * s.sxy[idx[i]]).sum();
    let bsx: f64 = (0..m).map(|i| beta[i] * s.sx[idx[i]]).sum();
    let sse = s.syy - 2.0 * b0 * s.sy - 2.0 * bsxy + s.n * b0 * b0 + 2.0 * b0 * bsx + bsxx;
    sse.max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::num::rng::SplitMix64;

    fn leave_out(of: Vec<Option<usize>>, n: usize) -> Folds {
        Folds {
            of,
            n,
            scheme: Scheme::LeaveOut,
            description: String::new(),
        }
    }

    /// Direct ridge on the rows (standardised columns, centred target),
    /// the reference the sums must reproduce.
    fn direct(cols: &[Vec<f64>], y: &[f64], rows: &[usize], lambda: f64) -> (f64, Vec<f64>) {
        let n = rows.len() as f64;
        let m = cols.len();
        let mean: Vec<f64> = cols
            .iter()
            .map(|c| rows.iter().map(|&r| c[r]).sum::<f64>() / n)
            .collect();
        let sd: Vec<f64> = cols
            .iter()
            .zip(&mean)
            .map(|(c, mu)| (rows.iter().map(|&r| (c[r] - mu).powi(2)).sum::<f64>() / n).sqrt())
            .collect();
        let ybar = rows.iter().map(|&r| y[r]).sum::<f64>() / n;
        let z = DMatrix::from_fn(rows.len(), m, |i, j| (cols[j][rows[i]] - mean[j]) / sd[j]);
        let yc = DVector::from_fn(rows.len(), |i, _| y[rows[i]] - ybar);
        let mut a = z.transpose() * &z;
        for p in 0..m {
            a[(p, p)] += lambda * n;
        }
        let w = a.cholesky().unwrap().solve(&(z.transpose() * yc));
        let beta: Vec<f64> = (0..m).map(|j| w[j] / sd[j]).collect();
        let b0 = ybar - beta.iter().zip(&mean).map(|(b, m)| b * m).sum::<f64>();
        (b0, beta)
    }

    #[test]
    fn sums_reproduce_direct_ridge_and_its_held_out_error() {
        let mut rng = SplitMix64::new(7);
        let n = 300;
        let cols: Vec<Vec<f64>> = (0..3)
            .map(|j| (0..n).map(|_| 30.0 + j as f64 + rng.symmetric()).collect())
            .collect();
        let y: Vec<f64> = (0..n)
            .map(|r| 2.0 * cols[0][r] - cols[2][r] + 0.1 * rng.symmetric())
            .collect();
        let fold: Vec<Option<usize>> = (0..n).map(|r| Some(r * 3 / n)).collect();
        let d = Design::new(&cols, &y, &leave_out(fold, 3));
        let train: Vec<usize> = (0..n).filter(|r| r * 3 / n != 1).collect();
        let (b0, beta) = direct(&cols, &y, &train, 1e-3);
        let c = d.fit(&[0, 1, 2], 1e-3, true, Some(1)).unwrap();
        // Same normal equations formed two ways: agreement to ~1e-9
        // (the sums lose about two digits to the centring of columns near 30).
        assert!((c.intercept - b0).abs() < 1e-7, "{} vs {b0}", c.intercept);
        for (a, b) in c.beta.iter().zip(&beta) {
            assert!((a - b).abs() < 1e-8, "{a} vs {b}");
        }
        // Held-out error of fold 1 from its sums against the rows.
        let held: Vec<usize> = (0..n).filter(|r| r * 3 / n == 1).collect();
        let sse: f64 = held
            .iter()
            .map(|&r| {
                let p = b0 + (0..3).map(|j| beta[j] * cols[j][r]).sum::<f64>();
                (y[r] - p).powi(2)
            })
            .sum();
        let cv = d.cv(&[0, 1, 2], 1e-3, true).unwrap();
        assert!(
            cv.mse > 0.0 && cv.mse < 0.05,
            "noise variance 0.01/3: {}",
            cv.mse
        );
        let fold_sums = &d.folds[1];
        let mut bv = DVector::zeros(3);
        for j in 0..3 {
            bv[j] = c.beta[j] * d.scale[j];
        }
        let e = sse_on(fold_sums, &[0, 1, 2], c.intercept, &bv);
        assert!((e - sse).abs() < 1e-6 * sse.max(1.0), "{e} vs {sse}");
    }

    /// A column constant on a training set (a filtered speed held at
    /// 3000 rpm, squared: ~9e6, with an intercept) gets weight 0 there:
    /// its `Σx² - n mu²` is rounding error, and a weight fitted to it
    /// used to be tens of um per unit of the column's spread.
    #[test]
    fn a_column_constant_in_training_gets_no_weight() {
        let n = 2000;
        let mut rng = SplitMix64::new(3);
        let t: Vec<f64> = (0..n).map(|_| rng.symmetric()).collect();
        // Constant in fold 0 (the training set of fold 1), moving in fold 1.
        let speed: Vec<f64> = (0..n)
            .map(|r| {
                if r < n / 2 {
                    9.0e6
                } else {
                    9.0e6 + 1.0e5 * rng.symmetric()
                }
            })
            .collect();
        let y: Vec<f64> = t.iter().map(|v| 50.0 + 2.0 * v).collect();
        let folds = Folds {
            of: (0..n).map(|r| Some(r * 2 / n)).collect(),
            n: 2,
            scheme: Scheme::Forward { first: 1 },
            description: String::new(),
        };
        let d = Design::new(&[t, speed], &y, &folds);
        let c = d.fit(&[0, 1], 1e-6, true, Some(1)).unwrap();
        assert_eq!(c.beta[1], 0.0, "{:?}", c.beta);
        assert!((c.beta[0] - 2.0).abs() < 1e-4, "{:?}", c.beta);
    }

    /// A scored fold with a single training row is skipped, not the end
    /// of every candidate.
    #[test]
    fn a_fold_with_one_training_row_is_skipped() {
        let n = 41;
        let x: Vec<f64> = (0..n).map(|r| (r as f64 * 0.37).sin()).collect();
        let y: Vec<f64> = x.iter().map(|v| 1.0 + 2.0 * v).collect();
        // Block 0 is one row: fold 1 would train on it alone.
        let of = (0..n)
            .map(|r| Some(if r == 0 { 0 } else { 1 + (r - 1) * 2 / (n - 1) }))
            .collect();
        let folds = Folds {
            of,
            n: 3,
            scheme: Scheme::Forward { first: 1 },
            description: String::new(),
        };
        let d = Design::new(&[x], &y, &folds);
        let cv = d.cv(&[0], 1e-6, true).expect("fold 2 still scores");
        assert!(cv.mse < 1e-8, "{}", cv.mse);
    }

    #[test]
    fn without_intercept_the_fit_goes_through_the_origin() {
        let n = 50;
        let x: Vec<f64> = (0..n).map(|r| r as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 * v).collect();
        let fold: Vec<Option<usize>> = (0..n).map(|r| Some(r % 2)).collect();
        let d = Design::new(&[x], &y, &leave_out(fold, 2));
        let c = d.fit(&[0], 0.0, false, None).unwrap();
        assert_eq!(c.intercept, 0.0);
        assert!((c.beta[0] - 3.0).abs() < 1e-9);
        assert!(d.cv(&[0], 0.0, false).unwrap().mse < 1e-12);
    }

    #[test]
    fn forward_folds_fit_on_the_blocks_before_and_skip_the_first() {
        let mut rng = SplitMix64::new(11);
        let n = 240;
        let cols: Vec<Vec<f64>> = (0..2)
            .map(|_| (0..n).map(|_| rng.symmetric()).collect())
            .collect();
        let y: Vec<f64> = (0..n)
            .map(|r| 1.5 * cols[0][r] + 0.5 * cols[1][r] + 0.05 * rng.symmetric())
            .collect();
        let of: Vec<Option<usize>> = (0..n).map(|r| Some(r * 4 / n)).collect();
        let folds = Folds {
            of,
            n: 4,
            scheme: Scheme::Forward { first: 1 },
            description: String::new(),
        };
        let d = Design::new(&cols, &y, &folds);
        assert!(d.fit(&[0, 1], 1e-3, true, Some(0)).is_none());
        // The model scoring block 2 is the direct ridge on blocks 0 and 1.
        let past: Vec<usize> = (0..n / 2).collect();
        let (b0, beta) = direct(&cols, &y, &past, 1e-3);
        let c = d.fit(&[0, 1], 1e-3, true, Some(2)).unwrap();
        // Same normal equations two ways (columns near 0: ~1e-12 apart).
        assert!((c.intercept - b0).abs() < 1e-9, "{} vs {b0}", c.intercept);
        for (a, b) in c.beta.iter().zip(&beta) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        // CV pools blocks 1..3 only: its mse is the noise variance
        // (0.05^2/3 ~ 8e-4) plus a little estimation error, well below 0.01.
        let cv = d.cv(&[0, 1], 1e-3, true).unwrap();
        assert!(cv.mse > 1e-4 && cv.mse < 1e-2, "{}", cv.mse);
    }
}
