//! Nguyen-Widrow initial weights, as MATLAB's `initnw` sets them.
//!
//! Nguyen & Widrow (1990) spread the hidden neurons' active regions evenly
//! over the input space, so training starts with every neuron doing
//! something instead of saturated or redundant. `initnw` for inputs
//! already in [-1, 1] (`mapminmax` did that): random unit directions of
//! length `0.7 n^(1/m)`, biases spaced linearly over `[-beta, beta]`,
//! both then stretched by half the width of the transfer function's active
//! region (tansig [-2, 2], logsig [-4, 4]) and shifted to its centre. The
//! purelin output layer has no active region, so `initnw` falls back to
//! `rands` (uniform on [-1, 1]) there, and so does this.

use super::net::Shape;
use crate::num::rng::SplitMix64;
use model_core::bp::Activation;

/// The active input region of a transfer function (MATLAB's `active`).
fn active(act: Activation) -> (f64, f64) {
    match act {
        Activation::Tansig => (-2.0, 2.0),
        Activation::Logsig => (-4.0, 4.0),
        Activation::Purelin => (-1.0, 1.0),
    }
}

/// A parameter vector in [`Shape`]'s layout, drawn from `rng`.
pub fn nguyen_widrow(shape: Shape, act: Activation, rng: &mut SplitMix64) -> Vec<f64> {
    let Shape { m, n, .. } = shape;
    let beta = 0.7 * (n as f64).powf(1.0 / m as f64);
    let (lo, hi) = active(act);
    let (half, centre) = ((hi - lo) / 2.0, (hi + lo) / 2.0);
    let mut w = vec![0.0; shape.params()];
    for j in 0..n {
        let row = &mut w[j * m..(j + 1) * m];
        let mut norm = 0.0;
        // A zero-length draw (probability ~0) would divide by zero: redraw.
        while norm < 1e-12 {
            row.iter_mut().for_each(|v| *v = rng.symmetric());
            norm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
        }
        let first_sign = if row[0] < 0.0 { -1.0 } else { 1.0 };
        row.iter_mut().for_each(|v| *v *= beta / norm * half);
        let spread = if n == 1 {
            0.0
        } else {
            -1.0 + 2.0 * j as f64 / (n - 1) as f64
        };
        w[n * m + j] = beta * spread * first_sign * half + centre;
    }
    for v in &mut w[n * m + n..] {
        *v = rng.symmetric();
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_have_the_nguyen_widrow_length_and_biases_span_it() {
        let shape = Shape { m: 4, n: 10, q: 3 };
        let w = nguyen_widrow(shape, Activation::Tansig, &mut SplitMix64::new(1));
        // |row| = 0.7 * 10^(1/4) * 2 (tansig half-width): exact to rounding.
        let beta = 0.7 * 10f64.powf(0.25) * 2.0;
        for j in 0..10 {
            let norm: f64 = w[j * 4..(j + 1) * 4]
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
                .sqrt();
            assert!((norm - beta).abs() < 1e-12, "{norm} {beta}");
        }
        let b1 = &w[40..50];
        assert!((b1[0].abs() - beta).abs() < 1e-12 && (b1[9].abs() - beta).abs() < 1e-12);
        assert!(w[50..].iter().all(|v| v.abs() <= 1.0));
        // Same seed, same draw.
        assert_eq!(
            w,
            nguyen_widrow(shape, Activation::Tansig, &mut SplitMix64::new(1))
        );
    }
}
