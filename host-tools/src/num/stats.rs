//! Statistics for sensor selection: Pearson correlation, least squares with
//! an intercept by QR, R^2 / adjusted R^2 / F / p-value, collinearity
//! figures (condition number, VIF), and the F distribution's survival
//! function through the regularized incomplete beta function.
//!
//! # Least squares by QR, once
//!
//! Every regression here has an intercept, so the regressors and the target
//! are centred first (the intercept then carries the means and drops out of
//! the fit) and scaled to unit length (so the regressors' cross-product is
//! their correlation matrix and the figures below are scale-free). The
//! centred, scaled matrix `A = [x_1 .. x_q, y]` (n rows) is factored once by
//! Householder QR, `A = Q R` ([`Basis::new`], O(n q^2)). Because `Q` has
//! orthonormal columns, regressing `y` on any subset `S` of the `x_j` is the
//! same least-squares problem as regressing column `y` of `R` on columns `S`
//! of `R`: a (q+1)-row problem, solved by a small Householder QR of its own
//! ([`Basis::fit`]). So the 2^k - 1 combinations of seed 000 and the levels
//! of seed 003 each cost O(q^3), not O(n q^2), and no normal equations
//! (`X^T X`, whose condition number is the square of the data's) are ever
//! formed. A regressor whose remaining length in the small QR is below
//! [`RANK_TOL`] of its own length lies in the span of the earlier ones: it is
//! skipped and the fit is flagged rank-deficient.
//!
//! # Figures
//!
//! With `n` rows, `p` regressors (the effective rank) and an intercept
//! (seed 003 Eq. 7-8, where Eq. 8's denominator is printed as `SSR` but is the
//! residual sum `SSE`, as the degrees of freedom show):
//!
//! - `R^2 = 1 - SSE/SST`, `SST = sum (y - mean y)^2`; the multiple correlation
//!   coefficient is `R = sqrt(R^2)` (seed 000's "multiple correlation
//!   coefficient").
//! - adjusted `R^2 = 1 - (1 - R^2) (n - 1) / (n - p - 1)`.
//! - `F = (SSR / p) / (SSE / (n - p - 1))` with `SSR = SST - SSE`, and its
//!   p-value `P(F(p, n-p-1) > F) = I_x(d2/2, d1/2)`, `x = d2 / (d2 + d1 F)`
//!   (Abramowitz & Stegun 26.6.2 with 26.5.2's symmetry), where `I` is the
//!   regularized incomplete beta function (`crate::num::distributions::betai`).
//! - VIF of regressor j = `1 / (1 - R_j^2)`, `R_j^2` from regressing it on the
//!   other regressors of the set; `1/VIF` is SPSS's "tolerance".
//! - condition number = `sigma_max / sigma_min` of the centred, unit-length
//!   regressors (the square root of the ratio of the extreme eigenvalues of
//!   their correlation matrix); 1 for one regressor, large when they are
//!   collinear (Belsley, Kuh & Welsch 1980 call 30 and above strong).

use crate::num::distributions::f_sf;
use nalgebra::DMatrix;

/// A regressor counts as dependent on the earlier ones when its remaining
/// length in the QR is below this fraction of its own length, i.e. when
/// `1 - R_j^2 < 1e-16`: collinear to working precision.
pub const RANK_TOL: f64 = 1e-8;

/// Arithmetic mean (NaN for an empty slice).
pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// The `q` quantile of `|v|` (nearest rank; 0 for an empty slice).
pub fn quantile_abs(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut a: Vec<f64> = v.iter().map(|e| e.abs()).collect();
    // Nearest rank: ceil(q n) - 1.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let i = ((q * a.len() as f64).ceil() as usize).clamp(1, a.len()) - 1;
    kth_smallest(&mut a, i)
}

/// How much of a band covers its residuals: of the `(residual,
/// half-width)` pairs with both finite, the share (%) with `|residual| <=
/// half-width`, and how many pairs that is (`None` without one).
pub fn coverage_pct(pairs: impl IntoIterator<Item = (f64, f64)>) -> Option<(f64, usize)> {
    let (n, inside) = pairs
        .into_iter()
        .filter(|(r, h)| r.is_finite() && h.is_finite())
        .fold((0usize, 0usize), |(n, i), (r, h)| {
            (n + 1, i + usize::from(r.abs() <= h))
        });
    (n > 0).then(|| (100.0 * inside as f64 / n as f64, n))
}

/// Pearson's correlation coefficient (seed 003 Eq. 11), or `None` when
/// either series is constant (or shorter than 2) and r is undefined.
pub fn pearson(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len().min(y.len());
    if n < 2 {
        return None;
    }
    let (mx, my) = (mean(&x[..n]), mean(&y[..n]));
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        let (da, db) = (a - mx, b - my);
        sxy += da * db;
        sxx += da * da;
        syy += db * db;
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return None;
    }
    Some((sxy / (sxx.sqrt() * syy.sqrt())).clamp(-1.0, 1.0))
}

/// Pearson correlation matrix of the columns (O(n m^2)). `Err(j)` names a
/// constant column, whose correlations are undefined.
pub fn pearson_matrix(cols: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, usize> {
    let m = cols.len();
    let centred: Vec<Vec<f64>> = cols
        .iter()
        .map(|c| {
            let mu = mean(c);
            c.iter().map(|v| v - mu).collect()
        })
        .collect();
    let norms: Vec<f64> = centred
        .iter()
        .map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt())
        .collect();
    if let Some(j) = norms.iter().position(|s| *s <= 0.0 || !s.is_finite()) {
        return Err(j);
    }
    let mut r = vec![vec![1.0; m]; m];
    for i in 0..m {
        for j in (i + 1)..m {
            let dot: f64 = centred[i].iter().zip(&centred[j]).map(|(a, b)| a * b).sum();
            let v = (dot / (norms[i] * norms[j])).clamp(-1.0, 1.0);
            r[i][j] = v;
            r[j][i] = v;
        }
    }
    Ok(r)
}

/// What a least-squares fit with intercept gives.
#[derive(Clone, Debug, PartialEq)]
pub struct Regression {
    /// Rows used.
    pub n: usize,
    /// Regressors used: the effective rank (fewer than asked when some are
    /// collinear to working precision).
    pub p: usize,
    /// Whether some regressor was dropped as collinear (`p` < asked).
    pub rank_deficient: bool,
    /// Coefficient of determination.
    pub r2: f64,
    /// Adjusted R^2 (NaN when `n - p - 1 <= 0`).
    pub adj_r2: f64,
    /// Regression F statistic (infinite for a perfect fit, NaN without
    /// residual degrees of freedom).
    pub f: f64,
    /// `P(F(p, n-p-1) > F)` (NaN without residual degrees of freedom).
    pub p_value: f64,
}

impl Regression {
    /// Multiple correlation coefficient `R = sqrt(R^2)`.
    pub fn multiple_r(&self) -> f64 {
        self.r2.max(0.0).sqrt()
    }

    fn from_sse(n: usize, p: usize, rank_deficient: bool, sse_over_sst: f64) -> Regression {
        let r2 = (1.0 - sse_over_sst).clamp(0.0, 1.0);
        let df2 = n as f64 - p as f64 - 1.0;
        let (adj_r2, f, p_value) = if df2 < 1.0 {
            (f64::NAN, f64::NAN, f64::NAN)
        } else if p == 0 {
            (r2, f64::NAN, f64::NAN)
        } else {
            let adj = 1.0 - (1.0 - r2) * (n as f64 - 1.0) / df2;
            let f = if r2 >= 1.0 {
                f64::INFINITY
            } else {
                (r2 / p as f64) / ((1.0 - r2) / df2)
            };
            (adj, f, f_sf(f, p as f64, df2))
        };
        Regression {
            n,
            p,
            rank_deficient,
            r2,
            adj_r2,
            f,
            p_value,
        }
    }
}

/// Collinearity of a set of regressors.
#[derive(Clone, Debug, PartialEq)]
pub struct Collinearity {
    /// `sigma_max / sigma_min` of the centred, unit-length regressors
    /// (infinite when they are rank-deficient).
    pub condition_number: f64,
    /// Variance inflation factor of each regressor, in the order given
    /// (infinite for one collinear with the others).
    pub vif: Vec<f64>,
}

impl Collinearity {
    /// Smallest tolerance `1/VIF` of the set (1 for a single regressor).
    pub fn min_tolerance(&self) -> f64 {
        self.vif.iter().map(|v| 1.0 / v).fold(1.0, f64::min)
    }
}

/// Why a [`Basis`] cannot be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum BasisError {
    /// Fewer than 3 rows.
    TooFewRows(usize),
    /// A regressor's length differs from the target's.
    Length,
    /// The target is constant: there is nothing to explain.
    ConstantTarget,
}

impl std::fmt::Display for BasisError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BasisError::TooFewRows(n) => write!(f, "{n} rows: a regression needs at least 3"),
            BasisError::Length => f.write_str("regressors and target differ in length"),
            BasisError::ConstantTarget => f.write_str("the target is constant"),
        }
    }
}

impl std::error::Error for BasisError {}

/// The QR factor of the centred, unit-length `[x_1 .. x_q, y]`, from which
/// any subset regression follows in O(q^3) (see the module docs).
#[derive(Clone, Debug)]
pub struct Basis {
    n: usize,
    q: usize,
    /// `R` as columns: `r[j]` is column j (length `min(n, q+1)`); column `q`
    /// is the target's.
    r: Vec<Vec<f64>>,
    /// Whether regressor j is constant (zero after centring).
    constant: Vec<bool>,
}

impl Basis {
    /// Factors the regressors `x` (columns) and target `y`.
    pub fn new(x: &[Vec<f64>], y: &[f64]) -> Result<Basis, BasisError> {
        let n = y.len();
        if n < 3 {
            return Err(BasisError::TooFewRows(n));
        }
        if x.iter().any(|c| c.len() != n) {
            return Err(BasisError::Length);
        }
        let q = x.len();
        let mut constant = vec![false; q];
        let mut a = DMatrix::<f64>::zeros(n, q + 1);
        for (j, col) in x.iter().chain(std::iter::once(&y.to_vec())).enumerate() {
            let mu = mean(col);
            let norm = col.iter().map(|v| (v - mu) * (v - mu)).sum::<f64>().sqrt();
            if norm <= 0.0 || !norm.is_finite() {
                if j == q {
                    return Err(BasisError::ConstantTarget);
                }
                constant[j] = true;
                continue; // stays zero
            }
            for (i, v) in col.iter().enumerate() {
                a[(i, j)] = (v - mu) / norm;
            }
        }
        let rm = a.qr().unpack_r();
        let r = (0..=q)
            .map(|j| (0..rm.nrows()).map(|i| rm[(i, j)]).collect())
            .collect();
        Ok(Basis { n, q, r, constant })
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.n
    }

    /// Number of regressors.
    pub fn regressors(&self) -> usize {
        self.q
    }

    /// Regresses the target on regressors `subset` (indices into `x`) with an
    /// intercept.
    pub fn fit(&self, subset: &[usize]) -> Regression {
        let cols: Vec<Vec<f64>> = subset
            .iter()
            .filter(|&&j| !self.constant[j])
            .map(|&j| self.r[j].clone())
            .collect();
        let dropped_constant = cols.len() < subset.len();
        let (rank, sse) = small_lsq(cols, self.r[self.q].clone());
        // SST = 1: the target column has unit length.
        Regression::from_sse(self.n, rank, dropped_constant || rank < subset.len(), sse)
    }

    /// Condition number and VIFs of regressors `subset`.
    pub fn collinearity(&self, subset: &[usize]) -> Collinearity {
        if subset.iter().any(|&j| self.constant[j]) {
            return Collinearity {
                condition_number: f64::INFINITY,
                vif: subset
                    .iter()
                    .map(|&j| if self.constant[j] { f64::INFINITY } else { 1.0 })
                    .collect(),
            };
        }
        let vif = subset
            .iter()
            .map(|&j| {
                if subset.len() == 1 {
                    return 1.0;
                }
                let others: Vec<Vec<f64>> = subset
                    .iter()
                    .filter(|&&k| k != j)
                    .map(|&k| self.r[k].clone())
                    .collect();
                // Unit-length column: the residual sum is 1 - R_j^2.
                let (_, tol) = small_lsq(others, self.r[j].clone());
                if tol > 0.0 {
                    1.0 / tol
                } else {
                    f64::INFINITY
                }
            })
            .collect();
        let rows = self.r.first().map_or(0, Vec::len);
        let m = DMatrix::from_fn(rows, subset.len(), |i, k| self.r[subset[k]][i]);
        let condition_number = match nalgebra::SVD::try_new(m, false, false, 1e-15, 10_000) {
            Some(svd) => {
                let s = svd.singular_values;
                let (lo, hi) = (s.min(), s.max());
                if lo > RANK_TOL * hi {
                    hi / lo
                } else {
                    f64::INFINITY
                }
            }
            None => f64::NAN,
        };
        Collinearity {
            condition_number,
            vif,
        }
    }
}

/// Least squares of `y` on `cols` (no intercept: the data are centred) by
/// Householder QR, skipping columns dependent on the earlier ones. Returns
/// the rank and the residual sum of squares.
fn small_lsq(mut cols: Vec<Vec<f64>>, mut y: Vec<f64>) -> (usize, f64) {
    let rows = y.len();
    let mut k = 0; // next pivot row
    for j in 0..cols.len() {
        if k >= rows {
            break;
        }
        let full = cols[j].iter().map(|v| v * v).sum::<f64>().sqrt();
        let (head, tail) = cols.split_at_mut(j + 1);
        let c = &mut head[j];
        let alpha = c[k..].iter().map(|v| v * v).sum::<f64>().sqrt();
        if full <= 0.0 || alpha <= RANK_TOL * full {
            continue; // dependent: in the span of the columns already taken
        }
        // Householder vector v = c[k..] + sign(c_k) alpha e_1.
        let beta = if c[k] >= 0.0 { alpha } else { -alpha };
        let mut v: Vec<f64> = c[k..].to_vec();
        v[0] += beta;
        let vv: f64 = v.iter().map(|a| a * a).sum();
        let reflect = |x: &mut [f64]| {
            let dot: f64 = v.iter().zip(x.iter()).map(|(a, b)| a * b).sum();
            let s = 2.0 * dot / vv;
            for (xi, vi) in x.iter_mut().zip(&v) {
                *xi -= s * vi;
            }
        };
        for other in tail.iter_mut() {
            reflect(&mut other[k..]);
        }
        reflect(&mut y[k..]);
        k += 1;
    }
    let sse = y[k.min(rows)..].iter().map(|v| v * v).sum();
    (k, sse)
}

/// Least squares with intercept of `y` on the columns `x`, by a direct QR of
/// the data: the reference that [`Basis::fit`] is tested against.
pub fn ols(x: &[Vec<f64>], y: &[f64]) -> Result<Regression, BasisError> {
    let n = y.len();
    if n < 3 {
        return Err(BasisError::TooFewRows(n));
    }
    let my = mean(y);
    let yc: Vec<f64> = y.iter().map(|v| v - my).collect();
    let sst: f64 = yc.iter().map(|v| v * v).sum();
    if sst <= 0.0 {
        return Err(BasisError::ConstantTarget);
    }
    let cols: Vec<Vec<f64>> = x
        .iter()
        .map(|c| {
            let mu = mean(c);
            c.iter().map(|v| v - mu).collect()
        })
        .collect();
    let (rank, sse) = small_lsq(cols, yc);
    Ok(Regression::from_sse(n, rank, rank < x.len(), sse / sst))
}

/// The `k`-th smallest of `v` (0-based) in `f64::total_cmp` order: the
/// value a sort and `v[k]` give (values equal in that order are the same
/// bits), found by selection in O(n) instead of a sort's O(n log n); `v`
/// is reordered. Medians and quantiles over a run's rows use it, so that
/// their work grows linearly with the rows.
pub fn kth_smallest(v: &mut [f64], k: usize) -> f64 {
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The median of `v` (the mean of the two middle values of an even count),
/// by [`kth_smallest`]; `None` when empty. `v` is reordered.
pub fn median(v: &mut [f64]) -> Option<f64> {
    let n = v.len();
    let lower = kth_smallest(v, n.checked_sub(1)? / 2);
    let upper = kth_smallest(v, n / 2);
    Some(0.5 * (lower + upper))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&mut [3.0, 1.0]), Some(2.0));
        assert_eq!(median(&mut []), None);
    }

    #[test]
    fn kth_smallest_is_the_sorted_value_bit_for_bit() {
        // Duplicates, both zeros and an infinity: every k agrees with a
        // sort in total_cmp order, bit for bit.
        let v: Vec<f64> = (0..301)
            .map(|k| match k % 7 {
                0 => 0.0,
                1 => -0.0,
                2 => f64::INFINITY,
                _ => ((k * 7919) % 97) as f64 / 7.0 - 5.0,
            })
            .collect();
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        for k in [0, 1, 42, 150, 299, 300] {
            let mut w = v.clone();
            assert_eq!(
                kth_smallest(&mut w, k).to_bits(),
                sorted[k].to_bits(),
                "{k}"
            );
        }
    }

    /// Relative-or-absolute closeness.
    fn close(a: f64, b: f64, rtol: f64, atol: f64) -> bool {
        (a - b).abs() <= atol + rtol * b.abs()
    }

    #[test]
    fn pearson_exact_cases() {
        // y = 2x + 1: r = 1 exactly (up to rounding); reversed: -1.
        let x = [1.0, 2.0, 3.0, 4.0];
        let y: Vec<f64> = x.iter().map(|v| 2.0 * v + 1.0).collect();
        assert!(close(pearson(&x, &y).unwrap(), 1.0, 0.0, 1e-15));
        let z: Vec<f64> = x.iter().map(|v| -v).collect();
        assert!(close(pearson(&x, &z).unwrap(), -1.0, 0.0, 1e-15));
        // x = 1,2,3 and y = 1,3,2: sxy = 1, sxx = syy = 2, r = 0.5.
        assert!(close(
            pearson(&[1.0, 2.0, 3.0], &[1.0, 3.0, 2.0]).unwrap(),
            0.5,
            0.0,
            1e-15
        ));
        assert_eq!(pearson(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0]), None);
        let m = pearson_matrix(&[vec![1.0, 2.0, 3.0], vec![1.0, 3.0, 2.0]]).unwrap();
        assert!(close(m[0][1], 0.5, 0.0, 1e-15) && m[1][0] == m[0][1]);
        assert_eq!(pearson_matrix(&[vec![1.0, 2.0], vec![5.0, 5.0]]), Err(1));
    }

    #[test]
    fn regression_hand_worked() {
        // x = 0,1,2,3; y = 1,3,2,5: fitted line y = 1.1 + 1.1 x (slope
        // sxy/sxx = 5.5/5), SST = 8.75, SSE = 8.75 - 1.1 * 5.5 = 2.7,
        // R^2 = 6.05/8.75, F = 6.05 / (2.7 / 2).
        let x = vec![vec![0.0, 1.0, 2.0, 3.0]];
        let y = [1.0, 3.0, 2.0, 5.0];
        let r = ols(&x, &y).unwrap();
        let r2 = 6.05 / 8.75;
        // Tolerance: a handful of roundings on O(1) numbers.
        assert!(close(r.r2, r2, 1e-13, 0.0), "{r:?}");
        assert!(close(r.adj_r2, 1.0 - (1.0 - r2) * 3.0 / 2.0, 1e-13, 0.0));
        assert!(close(r.f, 6.05 / 1.35, 1e-13, 0.0));
        // t^2 = F with 2 df: p = 1 - 1/sqrt(1 + 2/F)... for F(1, 2) the
        // survival function is 1 - sqrt(F / (F + 2)).
        let p = 1.0 - (r.f / (r.f + 2.0)).sqrt();
        assert!(close(r.p_value, p, 1e-12, 0.0), "{} vs {p}", r.p_value);
        // The R-factor path gives the same figures (1e-13: other roundings).
        let f = Basis::new(&x, &y).unwrap().fit(&[0]);
        assert_eq!((f.n, f.p, f.rank_deficient), (4, 1, false));
        assert!(close(f.r2, r.r2, 1e-13, 0.0) && close(f.p_value, r.p_value, 1e-12, 0.0));
    }

    #[test]
    fn collinear_regressor_is_dropped_and_flagged() {
        let x1 = vec![0.0, 1.0, 2.0, 3.0, 4.0];
        let x2: Vec<f64> = x1.iter().map(|v| 3.0 * v - 2.0).collect();
        let y = [0.5, 1.0, 3.0, 2.5, 4.5];
        let b = Basis::new(&[x1.clone(), x2], &y).unwrap();
        let both = b.fit(&[0, 1]);
        assert!(both.rank_deficient && both.p == 1);
        assert!(close(both.r2, b.fit(&[0]).r2, 1e-12, 0.0));
        let c = b.collinearity(&[0, 1]);
        assert!(c.condition_number.is_infinite() || c.condition_number > 1e7);
        assert!(c.vif.iter().all(|v| *v > 1e12), "{c:?}");
    }

    #[test]
    fn vif_and_condition_number_of_two_regressors() {
        // Two regressors with correlation r: VIF = 1 / (1 - r^2) each and
        // condition number sqrt((1 + r) / (1 - r)).
        let x1 = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let x2 = [2.0, 1.0, 4.0, 3.0, 6.0, 5.0];
        let r = pearson(&x1, &x2).unwrap();
        let y = [1.0, 0.0, 2.0, 1.5, 3.0, 2.0];
        let b = Basis::new(&[x1.to_vec(), x2.to_vec()], &y).unwrap();
        let c = b.collinearity(&[0, 1]);
        for v in &c.vif {
            assert!(close(*v, 1.0 / (1.0 - r * r), 1e-12, 0.0), "{c:?}");
        }
        assert!(close(
            c.condition_number,
            ((1.0 + r) / (1.0 - r)).sqrt(),
            1e-12,
            0.0
        ));
    }

    #[test]
    fn subset_fits_from_the_basis_agree_with_direct_qr() {
        // Two implementations agree: R-factor subsets vs a fresh QR of the
        // data, on a deterministic pseudo-random design with an offset of
        // 25 (temperature-like), to 1e-10 in R^2 (both backward-stable).
        let n = 200;
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let x: Vec<Vec<f64>> = (0..5)
            .map(|_| (0..n).map(|_| 25.0 + rnd()).collect())
            .collect();
        let y: Vec<f64> = (0..n)
            .map(|i| 3.0 * x[0][i] - x[2][i] + 0.5 * x[4][i] + 0.3 * rnd())
            .collect();
        let b = Basis::new(&x, &y).unwrap();
        for mask in 1u32..32 {
            let subset: Vec<usize> = (0..5).filter(|j| mask & (1 << j) != 0).collect();
            let cols: Vec<Vec<f64>> = subset.iter().map(|&j| x[j].clone()).collect();
            let direct = ols(&cols, &y).unwrap();
            let fast = b.fit(&subset);
            assert_eq!(direct.p, fast.p);
            assert!(close(fast.r2, direct.r2, 0.0, 1e-10), "{subset:?}");
            assert!(close(fast.p_value, direct.p_value, 1e-8, 1e-300));
        }
    }
}
