//! Linear least squares over fixed regressors, solved by SVD (never the
//! normal equations), and the first-order low-pass that turns an input into
//! a thermal response.

use nalgebra::{DMatrix, DVector};

/// The coefficients, one per column (0 for a dead one), from the
/// triangle `R` and `Q^T b` of the scaled live columns: an SVD of the
/// small `R` solved with a rank tolerance of 1e-10 of its largest singular
/// value, then each solution unscaled (`coef_j = x_k / scale_j`). The
/// dense and the streamed fit end here alike.
pub(super) fn solve_triangle(
    r: DMatrix<f64>,
    qtb: DVector<f64>,
    live: &[usize],
    scales: &[f64],
) -> Option<Vec<f64>> {
    let svd = crate::num::decomp::svd(r).ok()?;
    let smax = svd.singular_values.max();
    let x = svd.solve(&qtb, smax * 1e-10).ok()?;
    let mut coef = vec![0.0; scales.len()];
    for (k, &j) in live.iter().enumerate() {
        coef[j] = x[k] / scales[j];
    }
    Some(coef)
}

/// Each column's rms over `rows`: the scale a streamed fit divides it by
/// (so the rank tolerance means the same for um, K and kW). Computed once
/// for columns that several fits share ([`crate::num::batch::solve_scaled`]).
pub fn column_scales<C: AsRef<[f64]>>(cols: &[C], rows: &std::ops::Range<usize>) -> Vec<f64> {
    let n = rows.len() as f64;
    cols.iter()
        .map(|c| (c.as_ref()[rows.clone()].iter().map(|v| v * v).sum::<f64>() / n).sqrt())
        .collect()
}

/// The columns worth solving for: a finite scale above 1e-12 (a column
/// that is zero or not finite on the fit rows carries nothing).
pub(super) fn live_of(scales: &[f64]) -> Vec<usize> {
    (0..scales.len())
        .filter(|&j| scales[j] > 1e-12 && scales[j].is_finite())
        .collect()
}

/// Each column's scale over `rows` ([`column_scales`]) and the live
/// columns ([`live_of`]).
fn live_columns<C: AsRef<[f64]>>(
    cols: &[C],
    rows: &std::ops::Range<usize>,
) -> (Vec<f64>, Vec<usize>) {
    let scales = column_scales(cols, rows);
    let live = live_of(&scales);
    (scales, live)
}

/// First-order response `tau dy/dt = u - y` of `u` sampled at `t_s`,
/// discretised exactly for an input held over each step (zero-order hold,
/// as the twin does): `y_k = a y_(k-1) + (1 - a) u_(k-1)`,
/// `a = exp(-(t_k - t_(k-1)) / tau)`. Irregular sampling is fine. `y0` is the
/// state at the first sample (0 for a heat input on a cold machine, `u_0`
/// for a boundary temperature the machine was in equilibrium with).
pub fn lowpass(t_s: &[f64], u: &[f64], tau_s: f64, y0: f64) -> Vec<f64> {
    let [y] = lowpass_group::<1>(t_s, &[(u, tau_s, y0)]);
    y
}

/// One first-order response to compute: the input, its time constant, s,
/// and the state at the first sample (see [`lowpass`]).
pub type Response<'a> = (&'a [f64], f64, f64);

/// [`lowpass`] of each of `responses` (inputs of one length, sampled at
/// `t_s`), in one pass over the rows for up to four at a time: each
/// response's recursion waits on its own last value, so several side by
/// side fill the time one alone spends waiting. Each comes out the same to
/// the bit as [`lowpass`] computes it alone.
pub fn lowpass_each(t_s: &[f64], responses: &[Response]) -> Vec<Vec<f64>> {
    let mut out = Vec::with_capacity(responses.len());
    for group in responses.chunks(4) {
        match group.len() {
            1 => out.extend(lowpass_group::<1>(t_s, group)),
            2 => out.extend(lowpass_group::<2>(t_s, group)),
            3 => out.extend(lowpass_group::<3>(t_s, group)),
            _ => out.extend(lowpass_group::<4>(t_s, group)),
        }
    }
    out
}

/// [`lowpass`] of `M` responses side by side (`group.len() == M`). The
/// factor `a` of a step is reused while the step repeats (a run at a
/// fixed rate needs one `exp` a response; the same step gives the same
/// bits).
fn lowpass_group<const M: usize>(t_s: &[f64], group: &[Response]) -> [Vec<f64>; M] {
    let n = group[0].0.len();
    assert!(group.len() == M && group.iter().all(|g| g.0.len() == n));
    let mut y: [Vec<f64>; M] = std::array::from_fn(|_| Vec::with_capacity(n));
    let mut state: [f64; M] = std::array::from_fn(|i| group[i].2);
    let (mut a, mut b) = ([0.0; M], [0.0; M]);
    let mut last_dt = f64::NAN;
    for k in 0..n {
        if k > 0 {
            let dt = t_s[k] - t_s[k - 1];
            if dt != last_dt {
                last_dt = dt;
                for i in 0..M {
                    a[i] = (-dt / group[i].1).exp();
                    b[i] = 1.0 - a[i];
                }
            }
            for i in 0..M {
                state[i] = a[i] * state[i] + b[i] * group[i].0[k - 1];
            }
        }
        for i in 0..M {
            y[i].push(state[i]);
        }
    }
    y
}

/// A least-squares fit on the first `n_fit` rows, applied to every row.
#[derive(Debug, Clone)]
pub struct LinearFit {
    /// One coefficient per regressor (0 for a regressor that is zero on the
    /// fit rows).
    pub coef: Vec<f64>,
    /// Prediction on every row.
    pub pred: Vec<f64>,
    /// Sum of squared residuals on the fit rows.
    pub sse_fit: f64,
}

/// Fits `y ~ sum_j coef_j cols_j` on rows `0..n_fit` by SVD and predicts
/// every row. Columns are scaled to unit rms on the fit rows first (so the
/// rank tolerance means the same for um, K and kW); columns that are
/// (numerically) zero there get coefficient 0. `None` if there are fewer fit
/// rows than columns or the SVD fails.
pub fn fit(cols: &[Vec<f64>], y: &[f64], n_fit: usize) -> Option<LinearFit> {
    fit_penalised(cols, y, n_fit, &[])
}

/// [`fit`] with a ridge penalty `sum_j penalty_j coef_j^2` added to the
/// fit rows' sum of squares (`penalty` per column, missing entries 0): a
/// Gaussian prior of zero mean and variance `sigma^2 / penalty_j` on the
/// coefficient for residuals of variance `sigma^2`. Solved as least squares
/// on the fit rows stacked on one row `sqrt(penalty_j)` per penalised
/// column (target 0); `sse_fit` is over the fit rows only.
pub fn fit_penalised(
    cols: &[Vec<f64>],
    y: &[f64],
    n_fit: usize,
    penalty: &[f64],
) -> Option<LinearFit> {
    fit_rows_penalised(cols, y, 0..n_fit, penalty)
}

/// [`fit_penalised`] on the rows `rows` (any contiguous range) instead of
/// `0..n_fit`; `sse_fit` is over those rows.
pub fn fit_rows_penalised(
    cols: &[Vec<f64>],
    y: &[f64],
    rows: std::ops::Range<usize>,
    penalty: &[f64],
) -> Option<LinearFit> {
    let n = y.len();
    if rows.is_empty() || rows.end > n || cols.iter().any(|c| c.len() != n) {
        return None;
    }
    let (r0, n_fit) = (rows.start, rows.len());
    let (scales, live) = live_columns(cols, &rows);
    if live.len() > n_fit {
        return None;
    }
    let lambda = |j: usize| penalty.get(j).copied().unwrap_or(0.0).max(0.0);
    let ridge: Vec<usize> = (0..live.len()).filter(|&k| lambda(live[k]) > 0.0).collect();
    // R-SVD: a Householder QR of the tall scaled matrix, then the SVD of
    // the small triangular factor solves with a rank tolerance. Same
    // solution as an SVD of A; the QR does the O(n k^2) work once, without
    // forming U (n x k). A penalty row of column j in the scaled system is
    // sqrt(penalty_j) / scale_j (coef_j = x_j / scale_j).
    let n_rows = n_fit + ridge.len();
    let a = DMatrix::from_fn(n_rows, live.len(), |i, k| {
        let j = live[k];
        if i < n_fit {
            cols[j][r0 + i] / scales[j]
        } else if ridge[i - n_fit] == k {
            lambda(j).sqrt() / scales[j]
        } else {
            0.0
        }
    });
    let mut b = DVector::from_fn(n_rows, |i, _| if i < n_fit { y[r0 + i] } else { 0.0 });
    let qr = a.qr();
    qr.q_tr_mul(&mut b);
    let k = live.len();
    let coef = solve_triangle(qr.r(), b.rows(0, k).into_owned(), &live, &scales)?;
    let pred: Vec<f64> = (0..n)
        .map(|i| cols.iter().zip(&coef).map(|(c, w)| c[i] * w).sum())
        .collect();
    let sse_fit = rows.map(|i| (y[i] - pred[i]).powi(2)).sum();
    coef.iter().all(|c| c.is_finite()).then_some(LinearFit {
        coef,
        pred,
        sse_fit,
    })
}

/// The prediction `fixed + sum_j coef_j cols_j` on rows `rows` into
/// `out`, summed column by column in order (the bits of [`predict`]).
pub(super) fn predict_into(
    cols: &[&[f64]],
    coef: &[f64],
    fixed: Option<&[f64]>,
    rows: std::ops::Range<usize>,
    out: &mut [f64],
) {
    match fixed {
        Some(f) => out.copy_from_slice(&f[rows.clone()]),
        None => out.fill(0.0),
    }
    add_columns(cols, coef, rows, out);
}

/// `out += sum_j coef_j cols_j[rows]`, one column after the other.
fn add_columns(cols: &[&[f64]], coef: &[f64], rows: std::ops::Range<usize>, out: &mut [f64]) {
    for (c, w) in cols.iter().zip(coef) {
        for (q, v) in out.iter_mut().zip(&c[rows.clone()]) {
            *q += v * w;
        }
    }
}

/// Rows of a block of a prediction: summed over its columns while it
/// stays in a core's cache.
const PREDICT_ROWS: usize = 4096;

/// The prediction `fixed + sum_j coef_j cols_j` on all `n` rows, a block
/// of rows at a time (each row summed in the column order all the same).
pub fn predict(cols: &[&[f64]], coef: &[f64], fixed: Option<&[f64]>, n: usize) -> Vec<f64> {
    let mut pred = fixed.map_or_else(|| vec![0.0; n], <[f64]>::to_vec);
    for (b, out) in pred.chunks_mut(PREDICT_ROWS).enumerate() {
        let from = b * PREDICT_ROWS;
        add_columns(cols, coef, from..from + out.len(), out);
    }
    pred
}

/// Root mean square of `x` (0 for an empty slice).
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
    }
}

/// White-noise level of a series from its first differences, robustly:
/// `median|x_k - x_(k-1)| / 0.6745 / sqrt 2` (the MAD of a Gaussian; slow
/// signal and the odd step barely move a median).
pub fn noise_sigma(x: &[f64]) -> f64 {
    if x.len() < 3 {
        return 0.0;
    }
    median_abs_sigma(x.windows(2).map(|w| w[1] - w[0]), 2.0)
}

/// White-noise level of a series from its second differences:
/// `median|x_(k+1) - 2 x_k + x_(k-1)| / 0.6745 / sqrt 6`. Blind to straight
/// stretches, so smooth motion (a chiller's ramps included) does not count
/// as noise, only its turning points.
pub fn white_sigma(x: &[f64]) -> f64 {
    white_sigma_pooled(std::iter::once(x))
}

/// [`white_sigma`] of several series together (one median over the second
/// differences within each, none across their joins): the noise of one
/// sensor logged in several runs.
pub fn white_sigma_pooled<'a>(runs: impl IntoIterator<Item = &'a [f64]>) -> f64 {
    let d = runs
        .into_iter()
        .flat_map(|x| x.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]));
    median_abs_sigma(d, 6.0)
}

/// The sigma of white noise whose differences `d` have variance `var_factor`
/// sigma^2, from their median absolute value (0 without any).
fn median_abs_sigma(d: impl Iterator<Item = f64>, var_factor: f64) -> f64 {
    let mut d: Vec<f64> = d.map(f64::abs).collect();
    if d.is_empty() {
        return 0.0;
    }
    let k = d.len() / 2;
    crate::num::stats::kth_smallest(&mut d, k) / 0.6745 / var_factor.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::num::batch::fit_streamed;

    #[test]
    fn lowpass_matches_the_closed_form_step_response() {
        let t: Vec<f64> = (0..200).map(|k| 7.0 * k as f64).collect();
        let u = vec![2.0; 200];
        let y = lowpass(&t, &u, 300.0, 0.0);
        for (tk, yk) in t.iter().zip(&y) {
            let want = 2.0 * (1.0 - (-tk / 300.0).exp());
            assert!((yk - want).abs() < 1e-12, "{tk} {yk} {want}");
        }
    }

    #[test]
    fn responses_side_by_side_are_the_bits_of_the_plain_recursion() {
        // Irregular steps (some repeated, some not) and six responses
        // (a group of four and one of two): each must equal, bit for bit,
        // the recursion with `exp` taken at every step (the same
        // operations, so no tolerance).
        let t: Vec<f64> = (0..3000)
            .map(|k| 60.0 * k as f64 + if k % 7 == 3 { 13.5 } else { 0.0 })
            .collect();
        let u: Vec<f64> = (0..3000).map(|k| ((k / 97) % 4) as f64 - 0.3).collect();
        let plain = |tau: f64, y0: f64| -> Vec<f64> {
            let mut y = vec![y0];
            for k in 1..u.len() {
                let a = (-(t[k] - t[k - 1]) / tau).exp();
                y.push(a * y[k - 1] + (1.0 - a) * u[k - 1]);
            }
            y
        };
        let taus = [60.0, 300.0, 900.0, 3600.0, 7200.0, 14400.0];
        let todo: Vec<Response> = taus.iter().map(|&tau| (&u[..], tau, 0.5)).collect();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for (got, &tau) in lowpass_each(&t, &todo).iter().zip(&taus) {
            assert_eq!(bits(got), bits(&plain(tau, 0.5)), "tau {tau}");
        }
        assert_eq!(bits(&lowpass(&t, &u, 900.0, 0.5)), bits(&plain(900.0, 0.5)));
    }

    #[test]
    fn fit_recovers_exact_coefficients_and_ignores_zero_columns() {
        let n = 50;
        let x1: Vec<f64> = (0..n).map(|k| (k as f64 * 0.3).sin()).collect();
        let x2: Vec<f64> = (0..n).map(|k| 1e4 * k as f64).collect();
        let y: Vec<f64> = (0..n).map(|k| 3.0 * x1[k] - 2e-5 * x2[k] + 0.5).collect();
        let cols = vec![vec![1.0; n], x1, x2, vec![0.0; n]];
        let f = fit(&cols, &y, 30).expect("fit");
        for (c, want) in f.coef.iter().zip([0.5, 3.0, -2e-5, 0.0]) {
            assert!((c - want).abs() <= 1e-9 * want.abs().max(1.0), "{c} {want}");
        }
        assert!(f.sse_fit < 1e-18);
        assert!((f.pred[n - 1] - y[n - 1]).abs() < 1e-9);
    }

    #[test]
    fn qr_then_svd_agrees_with_a_direct_svd_on_collinear_responses() {
        // Two first-order responses with close time constants: the
        // ill-conditioned case of every candidate.
        let t: Vec<f64> = (0..400).map(|k| 60.0 * k as f64).collect();
        let u: Vec<f64> = (0..400).map(|k| ((k / 37) % 3) as f64).collect();
        let a = lowpass(&t, &u, 3600.0, 0.0);
        let b = lowpass(&t, &u, 7200.0, 0.0);
        let y: Vec<f64> = (0..400)
            .map(|k| 2.0 * a[k] - 0.7 * b[k] + 0.01 * ((k * 7919) % 13) as f64)
            .collect();
        let cols = vec![vec![1.0; 400], a.clone(), b.clone()];
        let f = fit(&cols, &y, 300).expect("fit");
        let m = DMatrix::from_fn(300, 3, |i, j| cols[j][i]);
        let direct = m
            .svd(true, true)
            .solve(&DVector::from_column_slice(&y[..300]), 1e-14)
            .expect("svd");
        for j in 0..3 {
            assert!(
                (f.coef[j] - direct[j]).abs() < 1e-8 * direct[j].abs().max(1.0),
                "{j}"
            );
        }
    }

    #[test]
    fn a_penalised_fit_agrees_with_the_closed_form_ridge() {
        // y = 2 x + noise-free; penalty p on the slope only:
        // slope = sum(x y) / (sum(x^2) + p) with x centred (offset free).
        let n = 40;
        let x: Vec<f64> = (0..n).map(|k| k as f64 - 19.5).collect();
        let y: Vec<f64> = x.iter().map(|v| 1.0 + 2.0 * v).collect();
        let sxx: f64 = x.iter().map(|v| v * v).sum();
        let p = 0.5 * sxx;
        let f = fit_penalised(&[vec![1.0; n], x.clone()], &y, n, &[0.0, p]).expect("fit");
        assert!(
            (f.coef[1] - 2.0 * sxx / (sxx + p)).abs() < 1e-12,
            "{:?}",
            f.coef
        );
        assert!((f.coef[0] - 1.0).abs() < 1e-12);
        let free = fit_penalised(&[vec![1.0; n], x], &y, n, &[]).expect("fit");
        assert!((free.coef[1] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn the_streamed_fit_agrees_with_the_dense_one() {
        // Collinear responses, a ridge on two columns, a zero column, a
        // fixed part, rows in the middle and more rows than one QR block:
        // coefficients and predictions within 1e-9 relative (rounding of
        // two QR orders on a condition number near 1e4).
        let n = 5000;
        let t: Vec<f64> = (0..n).map(|k| 60.0 * k as f64).collect();
        let u: Vec<f64> = (0..n).map(|k| ((k / 97) % 4) as f64).collect();
        let a = lowpass(&t, &u, 3600.0, 0.0);
        let b = lowpass(&t, &u, 5400.0, 0.0);
        let fixed: Vec<f64> = (0..n).map(|k| 0.1 * (k as f64 * 0.01).sin()).collect();
        let y: Vec<f64> = (0..n)
            .map(|k| 0.5 + 2.0 * a[k] - 0.7 * b[k] + fixed[k] + 0.01 * ((k * 7919) % 13) as f64)
            .collect();
        let cols = vec![vec![1.0; n], a, b, vec![0.0; n], u];
        let penalty = [0.0, 30.0, 0.0, 5.0, 1e3];
        let target: Vec<f64> = y.iter().zip(&fixed).map(|(y, f)| y - f).collect();
        for rows in [0..n, 1000..4000] {
            let dense = fit_rows_penalised(&cols, &target, rows.clone(), &penalty).expect("dense");
            let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
            let s =
                fit_streamed(&refs, &y, Some(&fixed), rows.clone(), &penalty).expect("streamed");
            for (c, d) in s.coef.iter().zip(&dense.coef) {
                assert!((c - d).abs() <= 1e-9 * d.abs().max(1.0), "{c} {d}");
            }
            for k in [0, 1234, n - 1] {
                let want = dense.pred[k] + fixed[k];
                assert!((s.pred[k] - want).abs() <= 1e-9 * want.abs().max(1.0));
            }
            let sse: f64 = rows
                .map(|k| (y[k] - dense.pred[k] - fixed[k]).powi(2))
                .sum();
            assert!((s.sse_fit - sse).abs() <= 1e-9 * sse);
        }
        let y0: Vec<f64> = (0..10).map(f64::from).collect();
        assert!(fit_streamed(&[&[0.0; 10]], &y0, None, 0..10, &[]).is_none());
    }

    #[test]
    fn noise_sigma_of_white_noise() {
        // Deterministic uniform pseudo-noise, sigma 1/sqrt(12).
        let mut r = crate::num::rng::SplitMix64::new(12345);
        let x: Vec<f64> = (0..20_000).map(|_| r.uniform() - 0.5).collect();
        let sd = noise_sigma(&x);
        // Uniform, not Gaussian: the MAD rule is within ~10 %.
        assert!((sd / (1.0 / 12f64.sqrt()) - 1.0).abs() < 0.12, "{sd}");
    }
}
