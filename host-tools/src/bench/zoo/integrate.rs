//! The zoo's integrator: classical fourth-order Runge-Kutta with a fixed
//! sub-step, for `dx/dt = f(t, x)` with heat laws that may depend on the
//! state (a bearing whose preload grows with its temperature difference).
//!
//! The sub-step keeps `h * lambda_max <= MAX_H_RATE` (`lambda_max` bounded by
//! [`super::network::Network::max_rate_per_s`]): RK4 is stable up to 2.78
//! and its local error per step is about `(h lambda)^5 / 120`, so 0.25 gives
//! ~1e-5 of a step's change on the fastest mode and far less on the slow
//! ones the displacements follow. A fixed point of the RK4 map of a linear
//! system is its exact steady state, so long runs settle on it exactly.

/// Largest `h * lambda_max` of a sub-step.
pub const MAX_H_RATE: f64 = 0.25;

/// Sub-steps per sample step `dt_s` for a system whose fastest rate is at
/// most `max_rate_per_s`.
pub fn substeps(dt_s: f64, max_rate_per_s: f64) -> usize {
    let n = (dt_s * max_rate_per_s / MAX_H_RATE).ceil();
    if n.is_finite() && n >= 1.0 {
        n as usize
    } else {
        1
    }
}

/// Scratch space of RK4 for a state of fixed length.
#[derive(Debug, Clone)]
pub struct Rk4 {
    k: [Vec<f64>; 4],
    tmp: Vec<f64>,
}

impl Rk4 {
    /// Scratch for states of length `n`.
    pub fn new(n: usize) -> Self {
        Rk4 {
            k: std::array::from_fn(|_| vec![0.0; n]),
            tmp: vec![0.0; n],
        }
    }

    /// One step of length `h` from time `t`: `x` becomes `x(t + h)`.
    pub fn step<F>(&mut self, f: &mut F, t: f64, x: &mut [f64], h: f64)
    where
        F: FnMut(f64, &[f64], &mut [f64]),
    {
        let [k1, k2, k3, k4] = &mut self.k;
        let tmp = &mut self.tmp;
        f(t, x, k1);
        axpy(tmp, x, 0.5 * h, k1);
        f(t + 0.5 * h, tmp, k2);
        axpy(tmp, x, 0.5 * h, k2);
        f(t + 0.5 * h, tmp, k3);
        axpy(tmp, x, h, k3);
        f(t + h, tmp, k4);
        for i in 0..x.len() {
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
}

/// `out = x + a * k`.
fn axpy(out: &mut [f64], x: &[f64], a: f64, k: &[f64]) {
    for ((o, xi), ki) in out.iter_mut().zip(x).zip(k) {
        *o = xi + a * ki;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rk4_follows_an_exponential_decay() {
        // dx/dt = -x / 100 over 100 s in 10 steps of 10 s (h lambda = 0.1):
        // RK4's error per step is ~(0.1)^5/120 = 8e-8 relative; 10 steps
        // stay below 1e-6 of e^-1.
        let mut rk = Rk4::new(1);
        let mut x = [1.0];
        let mut f = |_t: f64, x: &[f64], d: &mut [f64]| d[0] = -x[0] / 100.0;
        for k in 0..10 {
            rk.step(&mut f, 10.0 * k as f64, &mut x, 10.0);
        }
        assert!((x[0] - (-1.0f64).exp()).abs() < 1e-6, "{}", x[0]);
        assert_eq!(substeps(60.0, 0.05), 12);
        assert_eq!(substeps(60.0, 0.0), 1);
    }
}
