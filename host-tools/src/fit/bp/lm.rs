//! Levenberg-Marquardt training, as MATLAB's `trainlm` does it.
//!
//! Each epoch forms the Jacobian `J` of the scaled outputs and the errors
//! `e`, then tries `(J^T J + mu I) dx = J^T e` with growing `mu` (x10 per
//! failure, up to `mu_max` 1e10) until a step lowers the SSE; a success
//! divides `mu` by 10 for the next epoch. The system is symmetric positive
//! definite for `mu > 0`, so it is solved by Cholesky (never an explicit
//! inverse); a factorisation that fails counts as a failed step. Training
//! stops at the epoch cap, at `mu_max`, at a vanishing gradient, or (with
//! validation rows) after `max_fail` epochs in a row without a new best
//! validation error, returning the best-validation weights (`max_fail` 6,
//! MATLAB's default).

use super::net::{self, Data, Shape};
use indicatif::ProgressBar;
use model_core::bp::Activation;
use nalgebra::{DMatrix, DVector};
use std::time::Instant;

/// `trainlm` settings.
#[derive(Clone, Debug)]
pub struct LmOptions {
    /// Epoch cap.
    pub epochs: usize,
    /// Epochs in a row without a better validation error before stopping.
    pub max_fail: usize,
    /// Training MSE (scaled) whose first crossing is recorded (not a stop).
    pub goal_mse: f64,
}

/// `trainlm`'s fixed constants (MATLAB defaults).
const MU0: f64 = 1e-3;
const MU_DEC: f64 = 0.1;
const MU_INC: f64 = 10.0;
const MU_MAX: f64 = 1e10;
/// MATLAB's `min_grad` on the MSE gradient.
const MIN_GRAD: f64 = 1e-7;

/// What a run did.
#[derive(Clone, Debug)]
pub struct LmReport {
    /// Weights returned (best validation error, or the last without validation).
    pub w: Vec<f64>,
    /// Epochs run.
    pub epochs: usize,
    /// The epoch whose weights were returned.
    pub best_epoch: usize,
    /// Why it stopped.
    pub stop: &'static str,
    /// Training MSE (scaled) after each epoch, epoch 0 = the start.
    pub train_mse: Vec<f64>,
    /// Validation MSE after each epoch (empty without validation rows).
    pub val_mse: Vec<f64>,
    /// First epoch with training MSE at or below the goal.
    pub goal_epoch: Option<usize>,
    /// Seconds from the start to that epoch.
    pub goal_seconds: Option<f64>,
    /// Seconds in all.
    pub seconds: f64,
}

/// One epoch's step: `(J^T J + mu I) dx = J^T e` with `mu` growing x10
/// until the training MSE `mse(w + dx)` drops below `perf`; the new
/// weights and their MSE, `mu` divided by 10 for the next epoch. `None`
/// once `mu` passes [`MU_MAX`].
fn damped_step(
    jj: &DMatrix<f64>,
    je: &DVector<f64>,
    (w, perf): (&[f64], f64),
    mu: &mut f64,
    mse: impl Fn(&[f64]) -> f64,
) -> Option<(Vec<f64>, f64)> {
    while *mu <= MU_MAX {
        let mut a = jj.clone();
        for d in 0..a.nrows() {
            a[(d, d)] += *mu;
        }
        let step = a.cholesky().map(|c| c.solve(je));
        if let Some(dx) = step.filter(|dx: &DVector<f64>| dx.iter().all(|v| v.is_finite())) {
            let trial: Vec<f64> = w.iter().zip(dx.iter()).map(|(a, b)| a + b).collect();
            let p = mse(&trial);
            if p < perf {
                *mu *= MU_DEC;
                return Some((trial, p));
            }
        }
        *mu *= MU_INC;
    }
    None
}

/// The weights to return: the best on validation so far, or the last
/// without validation rows.
struct BestWeights {
    w: Vec<f64>,
    epoch: usize,
    /// Best validation MSE (infinite without validation).
    val_mse: f64,
    /// Epochs in a row without a new best.
    fails: usize,
}

impl BestWeights {
    /// Takes in epoch `epoch`'s weights `w` and validation MSE `vp`; true
    /// when `max_fail` epochs in a row have brought no new best.
    fn update(&mut self, epoch: usize, w: &[f64], vp: Option<f64>, max_fail: usize) -> bool {
        match vp {
            Some(vp) if vp < self.val_mse => {
                self.val_mse = vp;
                self.w = w.to_vec();
                self.epoch = epoch;
                self.fails = 0;
                false
            }
            Some(_) => {
                self.fails += 1;
                self.fails >= max_fail
            }
            None => {
                self.w = w.to_vec();
                self.epoch = epoch;
                false
            }
        }
    }
}

/// Trains from `w0` on `train`, early-stopping on `val` if given.
pub fn train(
    shape: Shape,
    act: Activation,
    w0: &[f64],
    train: &Data,
    val: Option<&Data>,
    opts: &LmOptions,
    pb: Option<&ProgressBar>,
) -> LmReport {
    let start = Instant::now();
    let count = train.errors().max(1) as f64;
    let mse_of = |w: &[f64], d: &Data| net::sse(shape, act, w, d) / d.errors().max(1) as f64;
    let mut w = w0.to_vec();
    let mut perf = mse_of(&w, train);
    let mut best = BestWeights {
        w: w.clone(),
        epoch: 0,
        val_mse: val.map_or(f64::INFINITY, |v| mse_of(&w, v)),
        fails: 0,
    };
    let mut report = LmReport {
        w: Vec::new(),
        epochs: 0,
        best_epoch: 0,
        stop: "epoch cap",
        train_mse: vec![perf],
        val_mse: val.map(|_| vec![best.val_mse]).unwrap_or_default(),
        goal_epoch: None,
        goal_seconds: None,
        seconds: 0.0,
    };
    if perf <= opts.goal_mse {
        report.goal_epoch = Some(0);
        report.goal_seconds = Some(0.0);
    }
    let mut mu = MU0;
    for epoch in 1..=opts.epochs {
        let (jt, e) = net::jacobian_t(shape, act, &w, train);
        let je = &jt * &e;
        if 2.0 * je.norm() / count < MIN_GRAD {
            report.stop = "minimum gradient";
            break;
        }
        let jj = &jt * jt.transpose();
        drop(jt);
        let step = damped_step(&jj, &je, (&w, perf), &mut mu, |t| mse_of(t, train));
        report.epochs = epoch;
        if let Some(pb) = pb {
            pb.inc(1);
        }
        let Some((trial, p)) = step else {
            report.stop = "mu reached mu_max";
            break;
        };
        (w, perf) = (trial, p);
        report.train_mse.push(perf);
        if report.goal_epoch.is_none() && perf <= opts.goal_mse {
            report.goal_epoch = Some(epoch);
            report.goal_seconds = Some(start.elapsed().as_secs_f64());
        }
        let vp = val.map(|v| mse_of(&w, v));
        report.val_mse.extend(vp);
        if best.update(epoch, &w, vp, opts.max_fail) {
            report.stop = "validation stop";
            break;
        }
    }
    report.w = best.w;
    report.best_epoch = best.epoch;
    report.seconds = start.elapsed().as_secs_f64();
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::bp::init::nguyen_widrow;
    use crate::fit::bp::net::tests::toy;
    use crate::num::rng::SplitMix64;

    fn opts(epochs: usize) -> LmOptions {
        LmOptions {
            epochs,
            max_fail: 6,
            goal_mse: 0.0,
        }
    }

    #[test]
    fn accepted_steps_lower_the_sse_monotonically() {
        let shape = Shape { m: 3, n: 6, q: 2 };
        let d = toy(80, 1);
        let w0 = nguyen_widrow(shape, Activation::Tansig, &mut SplitMix64::new(2));
        let r = train(shape, Activation::Tansig, &w0, &d, None, &opts(30), None);
        // Only accepted steps are recorded, and a step is accepted only if
        // it lowers the SSE: strictly decreasing, exactly.
        assert!(
            r.train_mse.windows(2).all(|p| p[1] < p[0]),
            "{:?}",
            r.train_mse
        );
        assert!(r.train_mse.len() > 10);
    }

    #[test]
    fn a_tiny_net_recovers_a_known_function() {
        // t = 0.8 tanh(1.5 x1 - x2 + 0.3) - 0.4 tanh(x3 + 0.5 x1) + 0.1: a
        // 3-2-1 tansig net represents it exactly, so a 3-4-1 net trained by
        // LM must drive the MSE to ~0 (1e-8 allows for stopping short) and
        // predict fresh rows just as well (1e-6).
        let f = |x: &[f64]| {
            0.8 * (1.5 * x[0] - x[1] + 0.3).tanh() - 0.4 * (x[2] + 0.5 * x[0]).tanh() + 0.1
        };
        let mut r = SplitMix64::new(9);
        let mut make = |rows: usize| {
            let x = nalgebra::DMatrix::from_fn(rows, 3, |_, _| r.symmetric());
            let t =
                nalgebra::DMatrix::from_fn(rows, 1, |i, _| f(&[x[(i, 0)], x[(i, 1)], x[(i, 2)]]));
            Data { x, t }
        };
        let (d, fresh) = (make(200), make(100));
        let shape = Shape { m: 3, n: 4, q: 1 };
        let w0 = nguyen_widrow(shape, Activation::Tansig, &mut SplitMix64::new(4));
        let rep = train(shape, Activation::Tansig, &w0, &d, None, &opts(300), None);
        let mse = rep.train_mse.last().copied().unwrap();
        assert!(mse < 1e-8, "mse {mse}, stop {}", rep.stop);
        let fresh_mse = net::sse(shape, Activation::Tansig, &rep.w, &fresh) / 100.0;
        assert!(fresh_mse < 1e-6, "{fresh_mse}");
    }

    #[test]
    fn validation_stop_returns_the_best_validation_weights() {
        let shape = Shape { m: 3, n: 12, q: 2 };
        let d = toy(40, 3);
        let v = toy(40, 4);
        let w0 = nguyen_widrow(shape, Activation::Tansig, &mut SplitMix64::new(2));
        let r = train(
            shape,
            Activation::Tansig,
            &w0,
            &d,
            Some(&v),
            &opts(200),
            None,
        );
        let best = r.val_mse.iter().copied().fold(f64::INFINITY, f64::min);
        let got = net::sse(shape, Activation::Tansig, &r.w, &v) / v.errors() as f64;
        // Same weights, same arithmetic: exact.
        assert_eq!(got, best);
        assert_eq!(r.val_mse[r.best_epoch], best);
    }
}
