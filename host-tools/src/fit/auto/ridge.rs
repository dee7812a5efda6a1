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
#[derive(Clone, Debug)]
pub struct CvScore {
    /// Pooled mean squared error over every held-out fold.
    pub mse: f64,
    /// Standard error of the mean of the per-fold mean squared errors.
    pub se: f64,
}

impl Design {
    /// Accumulates `cols[j][row]` (raw feature columns) and `y[row]`, row
    /// `row` belonging to fold `fold[row]` (`None`: not a calibration row).
    pub fn new(cols: &[Vec<f64>], y: &[f64], fold: &[Option<usize>], n_folds: usize) -> Self {
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
        let mut total = Sums::zeros(m);
        for f in &folds {
            total.n += f.n;
            total.sx += &f.sx;
            total.sxx += &f.sxx;
            total.sxy += &f.sxy;
            total.sy += f.sy;
            total.syy += f.syy;
        }
        Self {
            scale,
            folds,
            total,
        }
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
        let (mut sse, mut n) = (0.0, 0.0);
        for f in &self.folds {
            if f.n == 0.0 {
                continue;
            }
            let train = self.total.minus(f);
            let (b0, beta) = solve(&train, idx, lambda, intercept)?;
            let e = sse_on(f, idx, b0, &beta);
            per_fold.push(e / f.n);
            sse += e;
            n += f.n;
        }
        if per_fold.is_empty() || n == 0.0 {
            return None;
        }
        let k = per_fold.len() as f64;
        let mean = per_fold.iter().sum::<f64>() / k;
        let var = per_fold.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0).max(1.0);
        Some(CvScore {
            mse: sse / n,
            se: (var / k).sqrt(),
        })
    }

    /// The candidate fitted on every row but fold `fold` (`None`: on every
    /// row), in raw feature units.
    pub fn fit(
        &self,
        idx: &[usize],
        lambda: f64,
        intercept: bool,
        fold: Option<usize>,
    ) -> Option<Coefs> {
        let train = match fold {
            Some(f) => self.total.minus(self.folds.get(f)?),
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
    // Standard deviation of each column on this training set; a constant
    // column (d = 0) gets weight 0.
    let d: Vec<f64> = (0..m).map(|i| (c[(i, i)].max(0.0) / n).sqrt()).collect();
    let live: Vec<usize> = (0..m).filter(|&i| d[i] > 1e-12).collect();
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
    use crate::rng::SplitMix64;

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
        let d = Design::new(&cols, &y, &fold, 3);
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

    #[test]
    fn without_intercept_the_fit_goes_through_the_origin() {
        let n = 50;
        let x: Vec<f64> = (0..n).map(|r| r as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 * v).collect();
        let fold: Vec<Option<usize>> = (0..n).map(|r| Some(r % 2)).collect();
        let d = Design::new(&[x], &y, &fold, 2);
        let c = d.fit(&[0], 0.0, false, None).unwrap();
        assert_eq!(c.intercept, 0.0);
        assert!((c.beta[0] - 3.0).abs() < 1e-9);
        assert!(d.cv(&[0], 0.0, false).unwrap().mse < 1e-12);
    }
}
