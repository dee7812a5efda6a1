//! One ARMA(p, q) fit: Hannan-Rissanen starting values, then exact Gaussian
//! maximum likelihood ([`super::likelihood`]) by BFGS in the unconstrained
//! partial-autocorrelation coordinates of [`super::transform`], so every
//! candidate is stationary and invertible.
//!
//! Hannan and Rissanen (1982): fit a long AR(m) by Yule-Walker (biased
//! autocovariances, hence stationary), take its residuals `e_hat` as the
//! innovations, and regress `w_t` on `w_{t-1..p}` and `e_hat_{t-1..q}` by
//! least squares. This replaces seed 001's autocovariance fixed-point
//! iteration for the MA part (Eq. 21-24) as the starting point; the
//! optimiser then also starts from the Yule-Walker AR(p) with zero MA terms
//! (or from zero when one of those is unavailable), and the best optimum is kept (the likelihood of mixed
//! models often has more than one local maximum) among those whose MA part
//! is invertible with room to spare (see [`MEMORY_LEFT`]).

use super::likelihood::filter;
use super::ols;
use super::optimise::bfgs;
use super::transform::{constrain, unconstrain};
use super::yule_walker::{yule_walker, Method};
use anyhow::{bail, Result};
use serde::Serialize;

/// A fitted ARMA(p, q) of the differenced, standardised series `w`.
#[derive(Clone, Debug, Serialize)]
pub struct Estimate {
    /// AR order.
    pub p: usize,
    /// MA order.
    pub q: usize,
    /// `phi_1..phi_p`.
    pub phi: Vec<f64>,
    /// `theta_1..theta_q`.
    pub theta: Vec<f64>,
    /// Mean of `w` (statsmodels' `const` with `trend="c"`).
    pub mu: f64,
    /// Innovation variance (MLE).
    pub sigma2: f64,
    /// Exact log-likelihood.
    pub llf: f64,
    /// `-2 llf + 2 (p + q + 2)`: phi, theta, mu and sigma^2 are estimated.
    pub aic: f64,
    /// Optimiser iterations (best start).
    pub iterations: usize,
    /// Whether the optimiser's gradient test passed.
    pub converged: bool,
    /// Which start won: "hannan-rissanen", "yule-walker" or "zero".
    pub start: &'static str,
}

impl Estimate {
    /// The recursion's constant: `c = mu (1 - sum phi)`.
    pub fn constant(&self) -> f64 {
        self.mu * (1.0 - self.phi.iter().sum::<f64>())
    }
}

/// Hannan-Rissanen estimates of `(phi, theta)`, or `None` if the data do
/// not allow them.
pub fn hannan_rissanen(w: &[f64], p: usize, q: usize) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = w.len();
    let mean = w.iter().sum::<f64>() / n as f64;
    let x: Vec<f64> = w.iter().map(|v| v - mean).collect();
    if q == 0 {
        if p == 0 {
            return Some((Vec::new(), Vec::new()));
        }
        return yule_walker(w, p, Method::Mle)
            .ok()
            .map(|y| (y.phi, Vec::new()));
    }
    let m = (2 * (p + q)).max(10).min(n / 5);
    if m < p.max(q) {
        return None;
    }
    let long = yule_walker(w, m, Method::Mle).ok()?;
    let mut e = vec![0.0; n];
    for t in m..n {
        e[t] = x[t] - (1..=m).map(|i| long.phi[i - 1] * x[t - i]).sum::<f64>();
    }
    let start = (m + q).max(p);
    if n <= start + p + q + 1 {
        return None;
    }
    let mut cols = Vec::new();
    for i in 1..=p {
        cols.push(x[start - i..n - i].to_vec());
    }
    for j in 1..=q {
        cols.push(e[start - j..n - j].to_vec());
    }
    let fit = ols::fit(&cols, &x[start..]).ok()?;
    let (phi, theta) = fit.beta.split_at(p);
    Some((phi.to_vec(), theta.to_vec()))
}

/// An optimum is refused when the MA part's slowest mode still keeps this
/// share after the whole calibration span (`rho^n >= 0.01`): the exact
/// likelihood of an ARMA often peaks *on* the invertibility boundary (AR and
/// MA factors nearly cancelling, or an over-differenced series), where the
/// forecaster's recursive innovations never forget their start-up error.
const MEMORY_LEFT: f64 = 0.01;

/// Largest modulus of the inverse roots of `1 + theta_1 B + ... + theta_q B^q`
/// (0 for no MA part; 1 or more means not invertible).
pub fn ma_inverse_root_modulus(theta: &[f64]) -> f64 {
    if theta.iter().all(|v| *v == 0.0) {
        return 0.0;
    }
    let mut c = vec![1.0];
    c.extend_from_slice(theta);
    model_core::poly::roots(&c).map_or(f64::INFINITY, |r| {
        r.as_slice().iter().map(|z| z.abs()).fold(0.0, f64::max)
    })
}

/// Shrinks `(phi, theta)` towards zero until they are stationary and
/// invertible; the unconstrained vector, or `None`.
fn admissible_start(phi: &[f64], theta: &[f64]) -> Option<Vec<f64>> {
    let mut s = 1.0;
    for _ in 0..20 {
        let a: Vec<f64> = phi.iter().map(|v| v * s).collect();
        let b: Vec<f64> = theta.iter().map(|v| v * s).collect();
        if let Some(u) = unconstrain(&a, &b) {
            return Some(u);
        }
        s *= 0.8;
    }
    None
}

/// Fits ARMA(p, q) with a mean to `w` by exact maximum likelihood.
pub fn fit(w: &[f64], p: usize, q: usize) -> Result<Estimate> {
    let n = w.len();
    if n < 3 * (p + q + 2) {
        bail!("{n} samples are too few for {} parameters", p + q + 2);
    }
    let nf = n as f64;
    let objective = |u: &[f64]| -> f64 {
        let (phi, theta) = constrain(u, p);
        filter(w, &phi, &theta, None, false).map_or(f64::INFINITY, |f| -f.llf / nf)
    };
    let mut starts: Vec<(&'static str, Vec<f64>)> = Vec::new();
    if let Some(u) = hannan_rissanen(w, p, q).and_then(|(a, b)| admissible_start(&a, &b)) {
        starts.push(("hannan-rissanen", u));
    }
    if p > 0 && q > 0 {
        if let Some(u) = yule_walker(w, p, Method::Mle)
            .ok()
            .and_then(|y| admissible_start(&y.phi, &vec![0.0; q]))
        {
            starts.push(("yule-walker", u));
        }
    }
    if p + q > 0 && starts.len() < 2 {
        starts.push(("zero", vec![0.0; p + q]));
    }
    if starts.is_empty() {
        starts.push(("zero", Vec::new()));
    }
    let mut best: Option<(&'static str, super::optimise::Minimum)> = None;
    let mut edge: Option<f64> = None;
    for (name, u0) in starts {
        let m = bfgs(&objective, &u0, 1e-8, 400);
        if !m.f.is_finite() {
            continue;
        }
        let rho = ma_inverse_root_modulus(&constrain(&m.x, p).1);
        if rho.powf(nf) >= MEMORY_LEFT {
            edge = Some(edge.map_or(rho, |e: f64| e.max(rho)));
            continue;
        }
        if best.as_ref().is_none_or(|(_, b)| m.f < b.f) {
            best = Some((name, m));
        }
    }
    let Some((start, m)) = best else {
        if let Some(rho) = edge {
            bail!(
                "MA part at the invertibility boundary (largest inverse root {rho:.7}): the likelihood piles up there and the recursive forecaster would not forget its start within the {n} samples"
            );
        }
        bail!("the likelihood is not finite at any start");
    };
    let (phi, theta) = constrain(&m.x, p);
    let Some(f) = filter(w, &phi, &theta, None, false) else {
        bail!("the likelihood broke down at the optimum");
    };
    let k = (p + q + 2) as f64;
    Ok(Estimate {
        p,
        q,
        phi,
        theta,
        mu: f.mu,
        sigma2: f.sigma2,
        llf: f.llf,
        aic: -2.0 * f.llf + 2.0 * k,
        iterations: m.iterations,
        converged: m.converged,
        start,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg_normal(seed: u64, n: usize) -> Vec<f64> {
        // Sum of 12 uniforms minus 6: roughly N(0, 1), deterministic.
        let mut s = seed;
        (0..n)
            .map(|_| {
                (0..12)
                    .map(|_| {
                        s = s
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        (s >> 11) as f64 / (1u64 << 53) as f64
                    })
                    .sum::<f64>()
                    - 6.0
            })
            .collect()
    }

    #[test]
    fn recovers_an_arma11() {
        let e = lcg_normal(7, 2000);
        let mut w = vec![0.0; e.len()];
        for t in 1..e.len() {
            w[t] = 0.6 * w[t - 1] + e[t] + 0.3 * e[t - 1];
        }
        let est = fit(&w, 1, 1).unwrap();
        assert!((est.phi[0] - 0.6).abs() < 0.08, "{est:?}");
        assert!((est.theta[0] - 0.3).abs() < 0.08, "{est:?}");
        assert!((est.sigma2 - 1.0).abs() < 0.1, "{est:?}");
        // The optimum: no start does better than the one reported.
        let hr = hannan_rissanen(&w, 1, 1).unwrap();
        let at_hr = filter(&w, &hr.0, &hr.1, None, false).unwrap();
        assert!(est.llf >= at_hr.llf - 1e-9);
    }

    #[test]
    fn too_short_is_refused() {
        assert!(fit(&[1.0, 2.0, 3.0], 1, 1).is_err());
    }
}
