//! Gradient-descent back-propagation with momentum and an adaptive learning
//! rate (MATLAB's `traingdx`): the "traditional BP" of seed 000, which the
//! paper calls slow because it follows the gradient. It only serves the
//! convergence comparison of `--model gabp` (BP from random weights versus
//! from the GA's weights); the models `fit` writes are trained by
//! Levenberg-Marquardt ([`super::lm`]).
//!
//! MATLAB defaults: learning rate 0.01, x1.05 after an epoch that lowers the
//! error, x0.7 and momentum reset after one that raises it more than 4 %
//! (that step is discarded), momentum 0.9; the gradient is that of the MSE.

use super::net::{self, Data, Shape};
use indicatif::ProgressBar;
use model_core::bp::Activation;
use std::time::Instant;

const LR0: f64 = 0.01;
const LR_INC: f64 = 1.05;
const LR_DEC: f64 = 0.7;
const MOMENTUM: f64 = 0.9;
const MAX_PERF_INC: f64 = 1.04;

/// What a run did.
#[derive(Clone, Debug)]
pub struct GdReport {
    /// Epochs run.
    pub epochs: usize,
    /// First epoch with training MSE at or below the goal.
    pub goal_epoch: Option<usize>,
    /// Seconds to that epoch.
    pub goal_seconds: Option<f64>,
    /// Training MSE at the end.
    pub final_mse: f64,
    /// Seconds in all.
    pub seconds: f64,
}

/// Runs `traingdx` from `w0` until the training MSE reaches `goal_mse` or
/// `epochs` have passed.
pub fn train(
    shape: Shape,
    act: Activation,
    w0: &[f64],
    d: &Data,
    epochs: usize,
    goal_mse: f64,
    pb: Option<&ProgressBar>,
) -> GdReport {
    let start = Instant::now();
    let count = d.errors().max(1) as f64;
    let mut w = w0.to_vec();
    let (mut g, sse) = net::gradient(shape, act, &w, d);
    let mut perf = sse / count;
    let mut lr = LR0;
    // Descent direction of the MSE: 2 J^T e / N.
    let dir = |g: &[f64]| g.iter().map(|v| 2.0 * v / count).collect::<Vec<f64>>();
    let mut gx = dir(&g);
    let mut dx: Vec<f64> = gx.iter().map(|v| lr * v).collect();
    let mut report = GdReport {
        epochs: 0,
        goal_epoch: (perf <= goal_mse).then_some(0),
        goal_seconds: (perf <= goal_mse).then_some(0.0),
        final_mse: perf,
        seconds: 0.0,
    };
    for epoch in 1..=epochs {
        if report.goal_epoch.is_some() {
            break;
        }
        for (d, g) in dx.iter_mut().zip(&gx) {
            *d = MOMENTUM * *d + (1.0 - MOMENTUM) * lr * g;
        }
        let trial: Vec<f64> = w.iter().zip(&dx).map(|(a, b)| a + b).collect();
        let (g2, sse2) = net::gradient(shape, act, &trial, d);
        let perf2 = sse2 / count;
        if !(perf2.is_finite() && perf2 / perf <= MAX_PERF_INC) {
            lr *= LR_DEC;
            dx = gx.iter().map(|v| lr * v).collect();
        } else {
            if perf2 < perf {
                lr *= LR_INC;
            }
            w = trial;
            perf = perf2;
            g = g2;
            gx = dir(&g);
        }
        report.epochs = epoch;
        if let Some(pb) = pb {
            pb.inc(1);
        }
        if perf <= goal_mse {
            report.goal_epoch = Some(epoch);
            report.goal_seconds = Some(start.elapsed().as_secs_f64());
        }
    }
    report.final_mse = perf;
    report.seconds = start.elapsed().as_secs_f64();
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::bp::init::nguyen_widrow;
    use crate::fit::bp::net::tests::toy;
    use crate::num::rng::SplitMix64;

    #[test]
    fn gradient_descent_lowers_the_error() {
        let shape = Shape { m: 3, n: 5, q: 2 };
        let d = toy(60, 1);
        let w0 = nguyen_widrow(shape, Activation::Tansig, &mut SplitMix64::new(3));
        let start = net::sse(shape, Activation::Tansig, &w0, &d) / d.errors() as f64;
        let r = train(shape, Activation::Tansig, &w0, &d, 300, 0.0, None);
        // 300 epochs of traingdx on a smooth toy problem: at least halves the MSE.
        assert!(r.final_mse < 0.5 * start, "{} vs {start}", r.final_mse);
        assert_eq!(r.epochs, 300);
    }
}
