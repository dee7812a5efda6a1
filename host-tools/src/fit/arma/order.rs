//! Order selection by AIC (seed 001, Eq. 29, section 5.1: "set the order
//! range, calculate every ARMA(p, q), and take the p, q that minimise
//! AIC"). The extraction lost the criterion; seed 001 writes it as
//! `AIC(p, q) = n ln sigma_hat^2 + 2 (p + q)`, the large-sample form of
//! `-2 llf + 2 k`. We use the exact form, with `k = p + q + 2` (the mean and
//! `sigma^2` are estimated too), so that it equals statsmodels' `aic`; the
//! two differ by a constant only when every candidate is fitted on the same
//! `n`, which holds here (the exact likelihood uses every sample).

use super::estimate::{self, Estimate};
use rayon::prelude::*;
use serde_json::{json, Value};

/// One cell of the AIC table.
#[derive(Clone, Debug)]
pub struct Cell {
    /// AR order.
    pub p: usize,
    /// MA order.
    pub q: usize,
    /// The fit, or why it was refused.
    pub fit: Result<Estimate, String>,
}

impl Cell {
    /// The cell as JSON: the fit's figures or `{"refused": reason}`.
    pub fn json(&self) -> Value {
        match &self.fit {
            Ok(e) => json!({
                "p": self.p, "q": self.q, "aic": e.aic, "llf": e.llf, "sigma2": e.sigma2,
                "mu": e.mu, "phi": e.phi, "theta": e.theta,
                "iterations": e.iterations, "converged": e.converged, "start": e.start,
            }),
            Err(why) => json!({"p": self.p, "q": self.q, "refused": why}),
        }
    }
}

/// Fits every `(p, q)` in `0..=max_p x 0..=max_q` to `w` (in parallel, with
/// a progress bar on stderr if `progress`). Returns the table in `(p, q)`
/// order and the index of the smallest AIC (the earlier cell on a tie).
pub fn search(w: &[f64], max_p: usize, max_q: usize, progress: bool) -> (Vec<Cell>, Option<usize>) {
    let grid: Vec<(usize, usize)> = (0..=max_p)
        .flat_map(|p| (0..=max_q).map(move |q| (p, q)))
        .collect();
    let bar = progress.then(|| crate::num::progress::progress(grid.len(), "arma: AIC over (p, q)"));
    let cells: Vec<Cell> = grid
        .par_iter()
        .map(|&(p, q)| {
            let fit = estimate::fit(w, p, q).map_err(|e| format!("{e:#}"));
            let fit = match fit {
                Ok(e) if !e.aic.is_finite() => Err("AIC not finite".to_string()),
                other => other,
            };
            if let Some(b) = &bar {
                b.inc(1);
            }
            Cell { p, q, fit }
        })
        .collect();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let mut best: Option<(usize, f64)> = None;
    for (i, c) in cells.iter().enumerate() {
        if let Ok(e) = &c.fit {
            if best.is_none_or(|(_, a)| e.aic < a) {
                best = Some((i, e.aic));
            }
        }
    }
    (cells, best.map(|b| b.0))
}
