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
use serde::Serialize;

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
    /// The cell as reported: the fit's figures or why it was refused.
    pub fn report(&self) -> CellReport {
        match &self.fit {
            Ok(e) => CellReport::Fitted {
                aic: e.aic,
                converged: e.converged,
                iterations: e.iterations,
                llf: e.llf,
                mu: e.mu,
                p: self.p,
                phi: e.phi.clone(),
                q: self.q,
                sigma2: e.sigma2,
                start: e.start,
                theta: e.theta.clone(),
            },
            Err(why) => CellReport::Refused {
                p: self.p,
                q: self.q,
                refused: why.clone(),
            },
        }
    }
}

/// One cell of the AIC table as reported (fields in the JSON's key order;
/// the model's figures are those of the standardised, differenced series).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum CellReport {
    /// ARMA(p, q) fitted.
    Fitted {
        /// Akaike information criterion, `-2 llf + 2 (p + q + 2)`.
        aic: f64,
        /// Whether the optimiser converged.
        converged: bool,
        /// Optimiser iterations.
        iterations: usize,
        /// Exact Gaussian log-likelihood.
        llf: f64,
        /// Mean.
        mu: f64,
        /// AR order.
        p: usize,
        /// AR coefficients.
        phi: Vec<f64>,
        /// MA order.
        q: usize,
        /// Innovation variance.
        sigma2: f64,
        /// Where the optimiser started.
        start: &'static str,
        /// MA coefficients.
        theta: Vec<f64>,
    },
    /// ARMA(p, q) refused.
    Refused {
        /// AR order.
        p: usize,
        /// MA order.
        q: usize,
        /// Why.
        refused: String,
    },
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_cell_reports_its_orders_and_why() {
        let cell = Cell {
            p: 2,
            q: 1,
            fit: Err("AIC not finite".into()),
        };
        let v = serde_json::to_value(cell.report()).unwrap();
        assert_eq!(
            v,
            serde_json::json!({"p": 2, "q": 1, "refused": "AIC not finite"})
        );
    }
}
