//! Bounded Levenberg–Marquardt for small nonlinear least-squares problems
//! `min_x 0.5 |r(x)|^2`, `lo <= x <= hi`, with a forward-difference Jacobian.
//!
//! Used by [`super::calibrate`], where `r` is a simulation followed by a
//! linear projection, so an analytic Jacobian is not available and the few
//! parameters (4) make a numerical one cheap: `p + 1` residual evaluations
//! per iteration. The damping is Marquardt's scaled form
//! `(J^T J + lambda diag(J^T J)) dx = -J^T r` (Marquardt 1963; Nocedal &
//! Wright, *Numerical Optimization*, 2nd ed., section 10.3), so a parameter
//! in log units and one in plain units are damped alike. Bounds are kept by
//! projecting each trial point onto the box (parameters that sit on a bound
//! simply stay there); a rejected step raises lambda and retries without a
//! new Jacobian.

use anyhow::Result;
use nalgebra::{DMatrix, DVector};

/// Stopping rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Most Jacobian evaluations (iterations).
    pub max_iter: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub rel_cost_tol: f64,
    /// Stop when the largest step component is below this (parameter units).
    pub step_tol: f64,
    /// Finite-difference step (parameter units; the calibration's
    /// parameters are logs or O(1) exponents, so an absolute step fits).
    pub fd_step: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iter: 60,
            // 1e-7 of the cost is far below any difference a user could see
            // in an rmse (it moves the rmse by 5e-8 relative).
            rel_cost_tol: 1e-7,
            // 1e-6 in a log parameter is a 1 ppm change of a factor.
            step_tol: 1e-6,
            // Balances truncation (~h) and round-off of the simulation
            // (~1e-13 / h) for smooth residuals of O(1) parameters.
            fd_step: 1e-5,
        }
    }
}

/// The outcome of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct LmResult {
    /// Best parameters found.
    pub x: Vec<f64>,
    /// `0.5 |r(x)|^2` there.
    pub cost: f64,
    /// Iterations (Jacobians) used.
    pub iterations: usize,
    /// Residual evaluations used.
    pub evaluations: usize,
    /// Whether a tolerance (not the iteration limit) stopped it.
    pub converged: bool,
    /// Which rule stopped it.
    pub reason: &'static str,
}

fn cost(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

fn clamp(x: &[f64], lo: &[f64], hi: &[f64]) -> Vec<f64> {
    x.iter()
        .zip(lo.iter().zip(hi))
        .map(|(v, (l, h))| v.clamp(*l, *h))
        .collect()
}

/// Forward-difference Jacobian at `x` (stepping inwards at an upper bound).
fn jacobian(
    f: &mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    x: &[f64],
    r0: &[f64],
    hi: &[f64],
    h: f64,
) -> Result<DMatrix<f64>> {
    let mut j = DMatrix::zeros(r0.len(), x.len());
    for i in 0..x.len() {
        let mut xp = x.to_vec();
        let step = if x[i] + h <= hi[i] { h } else { -h };
        xp[i] += step;
        let rp = f(&xp)?;
        for (k, (a, b)) in rp.iter().zip(r0).enumerate() {
            j[(k, i)] = (a - b) / step;
        }
    }
    Ok(j)
}

/// Minimises `0.5 |f(x)|^2` over the box `[lo, hi]` from `x0`; `on_iter` is
/// called after each iteration with (iteration, cost) for progress output.
pub fn minimize(
    f: &mut dyn FnMut(&[f64]) -> Result<Vec<f64>>,
    x0: &[f64],
    lo: &[f64],
    hi: &[f64],
    opts: &LmOptions,
    on_iter: &mut dyn FnMut(usize, f64),
) -> Result<LmResult> {
    let p = x0.len();
    let mut x = clamp(x0, lo, hi);
    let mut r = f(&x)?;
    let mut c = cost(&r);
    let mut evals = 1;
    let mut lambda = 1e-3;
    let out = |x: Vec<f64>, c, it, evals, converged, reason| LmResult {
        x,
        cost: c,
        iterations: it,
        evaluations: evals,
        converged,
        reason,
    };
    for it in 1..=opts.max_iter {
        let j = jacobian(f, &x, &r, hi, opts.fd_step)?;
        evals += p;
        let jt = j.transpose();
        let a = &jt * &j;
        let mut g = &jt * DVector::from_column_slice(&r);
        // Parameters on a bound that the gradient pushes outwards are held
        // there (active set); otherwise the clamped step would keep
        // pointing out of the box and the iteration crawl along the face.
        let active: Vec<bool> = (0..p)
            .map(|i| (x[i] <= lo[i] && g[i] > 0.0) || (x[i] >= hi[i] && g[i] < 0.0))
            .collect();
        for (i, _) in active.iter().enumerate().filter(|(_, a)| **a) {
            g[i] = 0.0;
        }
        let mut accepted = false;
        for _ in 0..12 {
            let mut m = a.clone();
            for i in 0..p {
                if active[i] {
                    m.row_mut(i).fill(0.0);
                    m.column_mut(i).fill(0.0);
                    m[(i, i)] = 1.0;
                    continue;
                }
                // The floor keeps a parameter the residual ignores solvable.
                m[(i, i)] += lambda * a[(i, i)].max(1e-12);
            }
            let Some(dx) = m.cholesky().map(|ch| ch.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = x.iter().zip(dx.iter()).map(|(a, b)| a + b).collect();
            let trial = clamp(&trial, lo, hi);
            let step = trial
                .iter()
                .zip(&x)
                .fold(0.0f64, |s, (a, b)| s.max((a - b).abs()));
            let rt = f(&trial)?;
            evals += 1;
            let ct = cost(&rt);
            if ct < c {
                let rel = (c - ct) / c.max(f64::MIN_POSITIVE);
                x = trial;
                r = rt;
                c = ct;
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                on_iter(it, c);
                if rel < opts.rel_cost_tol {
                    return Ok(out(x, c, it, evals, true, "relative cost change"));
                }
                if step < opts.step_tol {
                    return Ok(out(x, c, it, evals, true, "step size"));
                }
                break;
            }
            if step < opts.step_tol {
                return Ok(out(x, c, it, evals, true, "step size"));
            }
            lambda *= 4.0;
        }
        if !accepted {
            return Ok(out(x, c, it, evals, true, "no downhill step"));
        }
    }
    Ok(out(x, c, opts.max_iter, evals, false, "iteration limit"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_an_exponential_decay() {
        // y = 3 exp(-0.7 t): recovers (ln 3, 0.7) from a far start.
        let t: Vec<f64> = (0..40).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 3.0 * (-0.7 * t).exp()).collect();
        let mut f = |x: &[f64]| -> Result<Vec<f64>> {
            Ok(t.iter()
                .zip(&y)
                .map(|(t, y)| x[0].exp() * (-x[1] * t).exp() - y)
                .collect())
        };
        let r = minimize(
            &mut f,
            &[0.0, 2.0],
            &[-5.0, 0.0],
            &[5.0, 5.0],
            &LmOptions::default(),
            &mut |_, _| {},
        );
        let r = r.unwrap_or_else(|e| panic!("{e}"));
        assert!(r.converged, "{r:?}");
        assert!((r.x[0] - 3f64.ln()).abs() < 1e-6, "{r:?}");
        assert!((r.x[1] - 0.7).abs() < 1e-6, "{r:?}");
    }

    #[test]
    fn stays_in_the_box() {
        // Unconstrained optimum x = 2 lies outside [0, 1]: ends on the bound.
        let mut f = |x: &[f64]| -> Result<Vec<f64>> { Ok(vec![x[0] - 2.0]) };
        let r = minimize(
            &mut f,
            &[0.5],
            &[0.0],
            &[1.0],
            &LmOptions::default(),
            &mut |_, _| {},
        );
        let r = r.unwrap_or_else(|e| panic!("{e}"));
        assert!((r.x[0] - 1.0).abs() < 1e-12, "{r:?}");
    }
}
