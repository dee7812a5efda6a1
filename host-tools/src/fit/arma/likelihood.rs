//! Exact Gaussian likelihood of an ARMA(p, q) with unknown mean, by the
//! Kalman filter (Harvey 1989, section 3.3; Brockwell and Davis 2002,
//! section 8.7). Seed 001 (Eq. 21-24) estimates the MA part from the
//! autocovariances by a fixed-point iteration; that estimate is neither
//! efficient nor the one behind its AIC (Eq. 29), whose `sigma^2` is the
//! maximum-likelihood residual variance. We maximise the exact likelihood.
//!
//! Model: `w_t = mu + u_t`, `u_t = sum phi_i u_{t-i} + e_t + sum theta_j e_{t-j}`,
//! `e ~ N(0, sigma^2)`. State `a_t` of size `r = max(p, q + 1)`:
//!
//! ```text
//! a_{t+1} = T a_t + R e_{t+1},  u_t = a_t[0],
//! T = [phi | I_{r-1}; 0],  R = [1, theta_1, .., theta_{r-1}]'
//! ```
//!
//! started from the stationary distribution (`P_1 = T P_1 T' + R R'`, solved
//! as a linear system in `vec P_1`). The filter runs with `sigma^2 = 1`
//! (everything scales with it). `mu` enters linearly: the filter is run on
//! `w` and on the constant 1 with the same gains (the augmented filter), so
//! `v_t(mu) = v^w_t - mu v^1_t` and the GLS estimate
//! `mu = sum v^1 v^w / F / sum (v^1)^2 / F` maximises the likelihood in
//! closed form; so does `sigma^2 = (1/n) sum v_t^2 / F_t`. What remains,
//!
//! ```text
//! llf = -n/2 (ln 2 pi + ln sigma^2 + 1) - 1/2 sum ln F_t,
//! ```
//!
//! is the exact log-likelihood maximised over `mu` and `sigma^2`: the same
//! number statsmodels' `ARIMA(.., trend="c").fit().llf` reports at its
//! optimum (it optimises `mu` and `sigma^2` numerically with the rest).
//! Once `P_t` stops changing (to 1e-13) the gains are frozen, which makes
//! long series cost `O(n r)` instead of `O(n r^2)`.

use nalgebra::{DMatrix, DVector};

/// What one filter pass gives.
#[derive(Clone, Debug)]
pub struct Filtered {
    /// Exact log-likelihood (at the MLE of `mu`, `sigma^2` if estimated).
    pub llf: f64,
    /// The mean used (estimated by GLS or given).
    pub mu: f64,
    /// Innovation variance `(1/n) sum v^2 / F`.
    pub sigma2: f64,
    /// One-step predictions of `w_t` from `w_1..w_{t-1}` (if asked for).
    pub predictions: Vec<f64>,
}

/// Stationary covariance of the state: `P = T P T' + R R'`.
fn initial_covariance(phi: &[f64], rvec: &[f64]) -> Option<Vec<f64>> {
    let r = rvec.len();
    let t = |i: usize, j: usize| -> f64 {
        let mut v = if j == 0 {
            phi.get(i).copied().unwrap_or(0.0)
        } else {
            0.0
        };
        if j == i + 1 {
            v += 1.0;
        }
        v
    };
    let m = r * r;
    // vec(P) with index i*r + j; (T P T')_{ij} = sum_{kl} T_ik P_kl T_jl.
    let a = DMatrix::from_fn(m, m, |row, col| {
        let (i, j) = (row / r, row % r);
        let (k, l) = (col / r, col % r);
        let id = if row == col { 1.0 } else { 0.0 };
        id - t(i, k) * t(j, l)
    });
    let b = DVector::from_fn(m, |row, _| rvec[row / r] * rvec[row % r]);
    let p = a.lu().solve(&b)?;
    let p: Vec<f64> = p.iter().copied().collect();
    if p.iter().all(|v| v.is_finite()) && p[0] > 0.0 {
        Some(p)
    } else {
        None
    }
}

/// The ARMA in state-space form: `T = [phi | I_{r-1}; 0]`, `R = [1, theta]'`.
struct StateSpace<'a> {
    phi: &'a [f64],
    /// `R`, zero-padded to the state size `r`.
    rvec: Vec<f64>,
    /// State size `max(p, q + 1)`.
    r: usize,
}

impl<'a> StateSpace<'a> {
    /// The state-space form of ARMA(`phi`, `theta`).
    fn new(phi: &'a [f64], theta: &[f64]) -> Self {
        let r = phi.len().max(theta.len() + 1);
        let mut rvec = vec![0.0; r];
        rvec[0] = 1.0;
        for (j, th) in theta.iter().enumerate() {
            rvec[j + 1] = *th;
        }
        Self { phi, rvec, r }
    }

    /// `phi_i`, 0 past the AR order.
    fn ph(&self, i: usize) -> f64 {
        self.phi.get(i).copied().unwrap_or(0.0)
    }

    /// `T x` for a state vector, into `out`.
    fn tmul(&self, x: &[f64], out: &mut [f64]) {
        let r = self.r;
        for i in 0..r {
            out[i] = self.ph(i) * x[0] + if i + 1 < r { x[i + 1] } else { 0.0 };
        }
    }

    /// The gain `K = T P[:,0] / F` into `k`; returns `F = P_00`.
    fn gain(&self, p: &[f64], k: &mut [f64]) -> f64 {
        let f = p[0];
        let col: Vec<f64> = (0..self.r).map(|i| p[i * self.r]).collect();
        self.tmul(&col, k);
        for v in k.iter_mut() {
            *v /= f;
        }
        f
    }

    /// The state's update `a <- T a + K e` (`next` is scratch).
    fn update_state(&self, a: &mut [f64], k: &[f64], e: f64, next: &mut [f64]) {
        self.tmul(a, next);
        for i in 0..self.r {
            a[i] = next[i] + k[i] * e;
        }
    }

    /// One covariance step `P <- T P T' + R R' - K K' F` (`pn`, `tp` are
    /// scratch); true once `P` has stopped changing (to 1e-13).
    fn step_covariance(
        &self,
        p: &mut Vec<f64>,
        pn: &mut Vec<f64>,
        tp: &mut [f64],
        k: &[f64],
        f: f64,
    ) -> bool {
        let (r, rvec) = (self.r, &self.rvec);
        // TP_{ij} = phi_i P_0j + P_{i+1,j};  (TP T')_{ij} = TP_i0 phi_j + TP_{i,j+1}.
        for i in 0..r {
            for j in 0..r {
                tp[i * r + j] =
                    self.ph(i) * p[j] + if i + 1 < r { p[(i + 1) * r + j] } else { 0.0 };
            }
        }
        let mut change: f64 = 0.0;
        let mut scale: f64 = 1.0;
        for i in 0..r {
            for j in 0..r {
                let v = tp[i * r] * self.ph(j)
                    + if j + 1 < r { tp[i * r + j + 1] } else { 0.0 }
                    + rvec[i] * rvec[j]
                    - k[i] * k[j] * f;
                pn[i * r + j] = v;
                change = change.max((v - p[i * r + j]).abs());
                scale = scale.max(v.abs());
            }
        }
        std::mem::swap(p, pn);
        change <= 1e-13 * scale
    }
}

/// The augmented filter's innovations: on `w` (`vw`), on the constant 1
/// (`v1`), and their variances `fs` (with `sigma^2 = 1`).
struct Innovations {
    vw: Vec<f64>,
    v1: Vec<f64>,
    fs: Vec<f64>,
}

impl Innovations {
    /// The GLS mean `sum v^1 v^w / F / sum (v^1)^2 / F`.
    fn gls_mean(&self) -> Option<f64> {
        let (mut num, mut den) = (0.0, 0.0);
        for ((a, b), f) in self.vw.iter().zip(&self.v1).zip(&self.fs) {
            num += a * b / f;
            den += b * b / f;
        }
        if den.is_nan() || den <= 0.0 {
            return None;
        }
        Some(num / den)
    }

    /// The log-likelihood at the mean `mu` and the MLE of `sigma^2`, and
    /// that `sigma^2`; `None` if it is not finite.
    fn concentrated_llf(&self, mu: f64) -> Option<(f64, f64)> {
        let (mut ssr, mut logf) = (0.0, 0.0);
        for ((a, b), f) in self.vw.iter().zip(&self.v1).zip(&self.fs) {
            let v = a - mu * b;
            ssr += v * v / f;
            logf += f.ln();
        }
        let nf = self.fs.len() as f64;
        let sigma2 = ssr / nf;
        let llf = -nf / 2.0 * ((2.0 * std::f64::consts::PI).ln() + sigma2.ln() + 1.0) - 0.5 * logf;
        llf.is_finite().then_some((llf, sigma2))
    }

    /// One-step predictions of `w` at the mean `mu`.
    fn predictions(&self, w: &[f64], mu: f64) -> Vec<f64> {
        w.iter()
            .zip(self.vw.iter().zip(&self.v1))
            .map(|(wt, (a, b))| wt - (a - mu * b))
            .collect()
    }
}

/// Runs the Kalman filter over `w` from the state covariance `p`, on `w`
/// and on the constant 1 with the same gains; freezes the gains once `P`
/// is steady. `None` if an innovation variance is not positive and finite.
fn innovations(ss: &StateSpace, w: &[f64], mut p: Vec<f64>) -> Option<Innovations> {
    let (n, r) = (w.len(), ss.r);
    let mut aw = vec![0.0; r];
    let mut a1 = vec![0.0; r];
    let mut inn = Innovations {
        vw: Vec::with_capacity(n),
        v1: Vec::with_capacity(n),
        fs: Vec::with_capacity(n),
    };
    let mut steady = false;
    let mut k = vec![0.0; r];
    let mut f = p[0];
    let mut tp = vec![0.0; r * r];
    let mut pn = vec![0.0; r * r];
    let mut next = vec![0.0; r];
    for &wt in w {
        if !steady {
            f = p[0];
            if !(f > 0.0 && f.is_finite()) {
                return None;
            }
            ss.gain(&p, &mut k);
        }
        let ew = wt - aw[0];
        let e1 = 1.0 - a1[0];
        inn.vw.push(ew);
        inn.v1.push(e1);
        inn.fs.push(f);
        ss.update_state(&mut aw, &k, ew, &mut next);
        ss.update_state(&mut a1, &k, e1, &mut next);
        if !steady && ss.step_covariance(&mut p, &mut pn, &mut tp, &k, f) {
            steady = true;
            f = ss.gain(&p, &mut k);
        }
    }
    Some(inn)
}

/// Runs the filter on `w` for the given coefficients. `mu = None` estimates
/// the mean (GLS); `Some(mu)` uses it. Returns `None` if the covariance
/// recursion breaks down (non-stationary input, non-finite numbers).
pub fn filter(
    w: &[f64],
    phi: &[f64],
    theta: &[f64],
    mu: Option<f64>,
    keep_predictions: bool,
) -> Option<Filtered> {
    if w.is_empty() {
        return None;
    }
    let ss = StateSpace::new(phi, theta);
    let p = initial_covariance(phi, &ss.rvec)?;
    let inn = innovations(&ss, w, p)?;
    let mu = match mu {
        Some(m) => m,
        None => inn.gls_mean()?,
    };
    let (llf, sigma2) = inn.concentrated_llf(mu)?;
    let predictions = if keep_predictions {
        inn.predictions(w, mu)
    } else {
        Vec::new()
    };
    Some(Filtered {
        llf,
        mu,
        sigma2,
        predictions,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_likelihood_is_the_sample_one() {
        // ARMA(0, 0): mu = mean, sigma^2 = population variance.
        let w = [1.0, 3.0, 2.0, 6.0];
        let f = filter(&w, &[], &[], None, true).unwrap();
        assert!((f.mu - 3.0).abs() < 1e-14);
        assert!((f.sigma2 - 3.5).abs() < 1e-14);
        let want = -2.0 * ((2.0 * std::f64::consts::PI).ln() + 3.5f64.ln() + 1.0);
        assert!((f.llf - want).abs() < 1e-12);
        assert!(f.predictions.iter().all(|p| (p - 3.0).abs() < 1e-14));
    }

    #[test]
    fn ar1_exact_likelihood_by_hand() {
        // AR(1) with mu = 0: first term N(0, 1/(1-phi^2)), then N(phi w_{t-1}, 1):
        // sigma^2 = ((1-phi^2) w_1^2 + sum (w_t - phi w_{t-1})^2) / n, sum ln F = -ln(1-phi^2).
        let (phi, w) = (0.6, [0.5, -1.0, 2.0, 0.3, 0.1]);
        let f = filter(&w, &[phi], &[], Some(0.0), true).unwrap();
        let mut ss = (1.0 - phi * phi) * w[0] * w[0];
        for t in 1..w.len() {
            ss += (w[t] - phi * w[t - 1]).powi(2);
        }
        let n = w.len() as f64;
        let want = -n / 2.0 * ((2.0 * std::f64::consts::PI).ln() + (ss / n).ln() + 1.0)
            + 0.5 * (1.0 - phi * phi).ln();
        assert!((f.llf - want).abs() < 1e-12, "{} {want}", f.llf);
        assert!((f.predictions[3] - phi * 2.0).abs() < 1e-14);
    }

    #[test]
    fn ma1_innovations_variance_tends_to_one() {
        // MA(1), theta = 0.5: F_1 = 1 + theta^2, F_t -> 1; predictions finite.
        let w: Vec<f64> = (0..200).map(|i| f64::from(i % 7) - 3.0).collect();
        let f = filter(&w, &[], &[0.5], None, true).unwrap();
        assert!(f.llf.is_finite() && f.sigma2 > 0.0);
    }
}
