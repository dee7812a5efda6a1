//! The change test of `refit`: is the old model's residual on new data
//! systematic, beyond what autocorrelated noise explains?
//!
//! The residual `r = y - yhat` of the old model is regressed on
//! `c0 + c1 tau + c2 yhat` by least squares (`tau` = hours since the start of
//! the run): `c0` is a bias (re-installation, new zero), `c1` a slow drift,
//! `c2` a gain error (the relation between temperature and displacement has
//! scaled). `H0: c0 = c1 = c2 = 0` is tested with a Wald statistic whose
//! covariance is Newey-West (Bartlett kernel, HAC), because thermal
//! residuals are strongly autocorrelated: a plain OLS covariance on 10,000
//! samples that carry the information of a few dozen would reject every
//! time. The bandwidth is Andrews' (1991, Econometrica 59, eq. 6.2 and 6.4)
//! AR(1) plug-in for the Bartlett kernel, `1.1447 (alpha n)^(1/3)` with
//! `alpha = 4 rho^2 / ((1 - rho)^2 (1 + rho)^2)`, `rho` the lag-1
//! autocorrelation of the auxiliary regression's residual; lags never cross
//! from one run into the next. Under `H0`, `W ~ chi^2(dof)`.

use crate::num::distributions::chi2_sf;
use nalgebra::{DMatrix, DVector};

/// One residual sample: hours since the run's start, the old prediction,
/// and the residual `y - yhat`.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Hours since the start of the run.
    pub tau_h: f64,
    /// The old model's prediction, um.
    pub yhat: f64,
    /// `y - yhat`, um.
    pub r: f64,
}

/// What the test found on one target.
#[derive(Clone, Debug)]
pub struct DriftTest {
    /// Samples used.
    pub n: usize,
    /// Bias `c0`, um.
    pub c0_um: f64,
    /// Drift `c1`, um per hour.
    pub c1_um_per_h: f64,
    /// Gain error `c2` (residual um per predicted um).
    pub c2: f64,
    /// Wald statistic with HAC covariance.
    pub wald: f64,
    /// Degrees of freedom (rank of the covariance).
    pub dof: usize,
    /// `P(chi^2(dof) > wald)`.
    pub p_value: f64,
    /// Bartlett lags used.
    pub lags: usize,
    /// Lag-1 autocorrelation of the auxiliary residual.
    pub rho1: f64,
    /// Effective sample size `n (1 - rho) / (1 + rho)` (reported, for scale).
    pub n_eff: f64,
    /// Largest `|c0 + c1 tau + c2 yhat|` over the samples, um: the biggest
    /// systematic error the test attributes to a change.
    pub effect_um: f64,
    /// `rmse(r) - rmse(r - fitted)`, um: what removing it gains in rmse.
    pub rmse_reduction_um: f64,
    /// `rmse(r)`, um.
    pub rmse_um: f64,
}

fn mean_std(v: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = v.clone().count().max(1) as f64;
    let m = v.clone().sum::<f64>() / n;
    let var = v.map(|x| (x - m) * (x - m)).sum::<f64>() / n;
    (m, var.sqrt())
}

/// Moore-Penrose inverse of a symmetric matrix, with eigenvalues below
/// `1e-10` of the largest treated as zero; also returns the rank.
/// `None` for non-finite entries or no convergence.
fn pinv_sym(a: &DMatrix<f64>) -> Option<(DMatrix<f64>, usize)> {
    let sym = (a + a.transpose()) * 0.5;
    let eig = crate::num::decomp::symmetric_eigen(sym).ok()?;
    let top = eig.eigenvalues.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let n = a.nrows();
    let mut inv = DMatrix::zeros(n, n);
    let mut rank = 0;
    for (j, lam) in eig.eigenvalues.iter().enumerate() {
        if top > 0.0 && lam.abs() > 1e-10 * top {
            rank += 1;
            let v = eig.eigenvectors.column(j);
            inv += (v * v.transpose()) / *lam;
        }
    }
    Some((inv, rank))
}

/// The auxiliary regression's data: the regressors `1, tau, yhat`, centred
/// and scaled (the Wald test of "all zero" is invariant to this
/// reparametrisation; a constant column is dropped), and the residual.
struct Design {
    /// `n x p` regressors.
    x: DMatrix<f64>,
    /// The old model's residual.
    r: DVector<f64>,
    /// Mean and standard deviation of `tau_h`, if its column is used.
    tau: Option<(f64, f64)>,
    /// Mean and standard deviation of `yhat`, if its column is used.
    yhat: Option<(f64, f64)>,
}

impl Design {
    /// The design over every sample of `runs` (`n` of them).
    fn new(runs: &[Vec<Sample>], n: usize) -> Self {
        let all = || runs.iter().flatten();
        let (m_tau, s_tau) = mean_std(all().map(|s| s.tau_h));
        let (m_yh, s_yh) = mean_std(all().map(|s| s.yhat));
        let tau = (s_tau > 1e-12 * m_tau.abs().max(1.0)).then_some((m_tau, s_tau));
        let yhat = (s_yh > 1e-12 * m_yh.abs().max(1.0)).then_some((m_yh, s_yh));
        let p = 1 + usize::from(tau.is_some()) + usize::from(yhat.is_some());
        let row = |s: &Sample| -> Vec<f64> {
            let mut v = vec![1.0];
            if let Some((m, sd)) = tau {
                v.push((s.tau_h - m) / sd);
            }
            if let Some((m, sd)) = yhat {
                v.push((s.yhat - m) / sd);
            }
            v
        };
        let mut x = DMatrix::<f64>::zeros(n, p);
        let mut r = DVector::zeros(n);
        for (i, s) in all().enumerate() {
            for (j, v) in row(s).into_iter().enumerate() {
                x[(i, j)] = v;
            }
            r[i] = s.r;
        }
        Self { x, r, tau, yhat }
    }

    /// The coefficients `c` of the scaled regressors back in raw units:
    /// `(c0 um, c1 um/h, c2)`.
    fn raw_coefficients(&self, c: &DVector<f64>) -> (f64, f64, f64) {
        let mut it = c.iter().skip(1);
        let c1 = match self.tau {
            Some((_, s_tau)) => it.next().copied().unwrap_or(0.0) / s_tau,
            None => 0.0,
        };
        let c2 = match self.yhat {
            Some((_, s_yh)) => it.next().copied().unwrap_or(0.0) / s_yh,
            None => 0.0,
        };
        let c0 =
            c[0] - c1 * self.tau.map_or(0.0, |(m, _)| m) - c2 * self.yhat.map_or(0.0, |(m, _)| m);
        (c0, c1, c2)
    }
}

/// Each run's `[start, end)` among the concatenated samples.
fn run_bounds(runs: &[Vec<Sample>]) -> Vec<(usize, usize)> {
    let mut start = 0;
    runs.iter()
        .map(|run| {
            let b = (start, start + run.len());
            start += run.len();
            b
        })
        .collect()
}

/// Lag-1 autocorrelation of `u` within runs, clamped to +-0.999.
fn lag1_autocorrelation(u: &DVector<f64>, bounds: &[(usize, usize)]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for &(a, b) in bounds {
        for k in a..b {
            den += u[k] * u[k];
            if k > a {
                num += u[k] * u[k - 1];
            }
        }
    }
    if den > 0.0 { num / den } else { 0.0 }.clamp(-0.999, 0.999)
}

/// Andrews' AR(1) plug-in bandwidth for the Bartlett kernel,
/// `1.1447 (alpha n)^(1/3)`, at most `n / 2`.
fn andrews_lags(rho: f64, n: usize) -> usize {
    let alpha = 4.0 * rho * rho / ((1.0 - rho).powi(2) * (1.0 + rho).powi(2));
    ((1.1447 * (alpha * n as f64).cbrt()).floor() as usize).min(n / 2)
}

/// Newey-West long-run covariance of the scores `g_k = x_k u_k`:
/// `Omega = Gamma_0 + sum_j w_j (Gamma_j + Gamma_j')` with Bartlett
/// weights, lags within runs only, divided by `n`.
fn newey_west(
    x: &DMatrix<f64>,
    u: &DVector<f64>,
    bounds: &[(usize, usize)],
    lags: usize,
) -> DMatrix<f64> {
    let (n, p) = (x.nrows(), x.ncols());
    let g: Vec<f64> = (0..n)
        .flat_map(|i| (0..p).map(move |j| (i, j)))
        .map(|(i, j)| x[(i, j)] * u[i])
        .collect();
    let mut omega = DMatrix::<f64>::zeros(p, p);
    for j in 0..=lags {
        let w = if j == 0 {
            0.5
        } else {
            1.0 - j as f64 / (lags as f64 + 1.0)
        };
        let mut gamma = [[0.0; 3]; 3];
        for &(a, b) in bounds {
            for k in (a + j)..b {
                let (lead, lag) = (&g[k * p..k * p + p], &g[(k - j) * p..(k - j) * p + p]);
                for (row, gl) in gamma.iter_mut().zip(lead) {
                    for (cell, gg) in row.iter_mut().zip(lag) {
                        *cell += gl * gg;
                    }
                }
            }
        }
        // Gamma_0 enters once: half of (Gamma_0 + Gamma_0').
        for r in 0..p {
            for c in 0..p {
                omega[(r, c)] += w * (gamma[r][c] + gamma[c][r]);
            }
        }
    }
    omega /= n as f64;
    omega
}

/// Runs the test over `runs` (each run's samples in time order).
pub fn drift_test(runs: &[Vec<Sample>]) -> Option<DriftTest> {
    let n = runs.iter().flatten().count();
    if n < 10 {
        return None;
    }
    let d = Design::new(runs, n);
    let (x, r) = (&d.x, &d.r);
    let nf = n as f64;
    let q = x.transpose() * x / nf;
    let (q_inv, _) = pinv_sym(&q)?;
    let c = &q_inv * (x.transpose() * r / nf);
    let fitted = x * &c;
    let u = r - &fitted;
    let bounds = run_bounds(runs);
    let rho = lag1_autocorrelation(&u, &bounds);
    let lags = andrews_lags(rho, n);
    let omega = newey_west(x, &u, &bounds, lags);
    let v = &q_inv * omega * &q_inv / nf;
    let (v_inv, dof) = pinv_sym(&v)?;
    let wald = (c.transpose() * v_inv * &c)[(0, 0)].max(0.0);
    let p_value = chi2_sf(wald, dof);
    let (c0, c1, c2) = d.raw_coefficients(&c);
    let rmse = |v: &DVector<f64>| (v.norm_squared() / nf).sqrt();
    Some(DriftTest {
        n,
        c0_um: c0,
        c1_um_per_h: c1,
        c2,
        wald,
        dof,
        p_value,
        lags,
        rho1: rho,
        n_eff: nf * (1.0 - rho) / (1.0 + rho),
        effect_um: fitted.iter().fold(0.0_f64, |m, v| m.max(v.abs())),
        rmse_reduction_um: rmse(r) - rmse(&u),
        rmse_um: rmse(r),
    })
}
