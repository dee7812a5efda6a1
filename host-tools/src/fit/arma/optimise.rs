//! A small quasi-Newton minimiser (BFGS with an Armijo backtracking line
//! search and central-difference gradients; Nocedal and Wright 2006,
//! algorithm 6.1). The likelihood has at most 20 free parameters here and
//! is cheap, so finite differences are adequate.

/// Where the minimiser stopped.
#[derive(Clone, Debug)]
pub struct Minimum {
    /// The point.
    pub x: Vec<f64>,
    /// The objective there.
    pub f: f64,
    /// Iterations used.
    pub iterations: usize,
    /// The gradient test passed (rather than the iteration limit or a
    /// failed line search at the precision floor).
    pub converged: bool,
}

fn gradient(f: &dyn Fn(&[f64]) -> f64, x: &[f64]) -> Vec<f64> {
    let mut xp = x.to_vec();
    (0..x.len())
        .map(|i| {
            let h = 1e-6 * (1.0 + x[i].abs());
            xp[i] = x[i] + h;
            let a = f(&xp);
            xp[i] = x[i] - h;
            let b = f(&xp);
            xp[i] = x[i];
            (a - b) / (2.0 * h)
        })
        .collect()
}

/// Minimises `f` from `x0`. `f` returns `+inf` where it is undefined; the
/// line search then backtracks. Stops when `max |grad| < gtol`.
pub fn bfgs(f: &dyn Fn(&[f64]) -> f64, x0: &[f64], gtol: f64, max_iter: usize) -> Minimum {
    let n = x0.len();
    let mut x = x0.to_vec();
    let mut fx = f(&x);
    if n == 0 || !fx.is_finite() {
        return Minimum {
            converged: fx.is_finite(),
            x,
            f: fx,
            iterations: 0,
        };
    }
    let mut g = gradient(f, &x);
    // Inverse Hessian approximation, row-major.
    let mut h = vec![0.0; n * n];
    for i in 0..n {
        h[i * n + i] = 1.0;
    }
    let mut iterations = 0;
    let mut converged = false;
    while iterations < max_iter {
        if g.iter().fold(0.0f64, |m, v| m.max(v.abs())) < gtol {
            converged = true;
            break;
        }
        iterations += 1;
        let mut d: Vec<f64> = (0..n)
            .map(|i| -(0..n).map(|j| h[i * n + j] * g[j]).sum::<f64>())
            .collect();
        let mut slope: f64 = d.iter().zip(&g).map(|(a, b)| a * b).sum();
        if slope.is_nan() || slope >= 0.0 {
            // Not a descent direction: restart from steepest descent.
            h.iter_mut()
                .enumerate()
                .for_each(|(k, v)| *v = if k % (n + 1) == 0 { 1.0 } else { 0.0 });
            d = g.iter().map(|v| -v).collect();
            slope = -g.iter().map(|v| v * v).sum::<f64>();
        }
        // Keep the first step modest in the unconstrained coordinates.
        let dmax = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut step = if dmax > 2.0 { 2.0 / dmax } else { 1.0 };
        let mut accepted = None;
        for _ in 0..40 {
            let xn: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + step * b).collect();
            let fnew = f(&xn);
            if fnew.is_finite() && fnew <= fx + 1e-4 * step * slope {
                accepted = Some((xn, fnew));
                break;
            }
            step *= 0.5;
        }
        let Some((xn, fnew)) = accepted else {
            // No decrease possible at this precision: as good as it gets.
            converged = g.iter().fold(0.0f64, |m, v| m.max(v.abs())) < 1e3 * gtol;
            break;
        };
        let gn = gradient(f, &xn);
        let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy: f64 = s.iter().zip(&y).map(|(a, b)| a * b).sum();
        if sy > 1e-16 {
            // H <- (I - rho s y') H (I - rho y s') + rho s s'.
            let rho = 1.0 / sy;
            let hy: Vec<f64> = (0..n)
                .map(|i| (0..n).map(|j| h[i * n + j] * y[j]).sum())
                .collect();
            let yhy: f64 = y.iter().zip(&hy).map(|(a, b)| a * b).sum();
            for i in 0..n {
                for j in 0..n {
                    h[i * n + j] += -rho * (hy[i] * s[j] + s[i] * hy[j])
                        + (rho * rho * yhy + rho) * s[i] * s[j];
                }
            }
        }
        let small = (fx - fnew).abs() <= 1e-15 * fx.abs().max(1.0);
        x = xn;
        fx = fnew;
        g = gn;
        if small && g.iter().fold(0.0f64, |m, v| m.max(v.abs())) < 1e2 * gtol {
            converged = true;
            break;
        }
    }
    Minimum {
        x,
        f: fx,
        iterations,
        converged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rosenbrock() {
        let f = |x: &[f64]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
        let m = bfgs(&f, &[-1.2, 1.0], 1e-8, 500);
        assert!(m.converged, "{m:?}");
        assert!(
            (m.x[0] - 1.0).abs() < 1e-5 && (m.x[1] - 1.0).abs() < 1e-5,
            "{m:?}"
        );
    }

    #[test]
    fn undefined_region_is_backtracked_out_of() {
        let f = |x: &[f64]| {
            if x[0] > 3.0 {
                f64::INFINITY
            } else {
                (x[0] - 2.9).powi(2)
            }
        };
        let m = bfgs(&f, &[0.0], 1e-9, 100);
        assert!((m.x[0] - 2.9).abs() < 1e-5, "{m:?}");
    }
}
