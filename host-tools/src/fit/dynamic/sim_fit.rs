//! The score the order searches and input selection rank by: the
//! system-identification fit % of a free-run simulation against the
//! measured target (seed 004, Eq. 4), computed by the model core's own
//! metric so that a search ranks by exactly the figure `eval` prints.

/// System-identification fit % of the predictions against the measured
/// values of `(y, yhat)` pairs: [`model_core::metrics`]'s `fit_pct`, or NaN
/// when it has no figure (no pairs, a non-finite simulation, overflow), so
/// that a search can drop the candidate.
pub fn fit_pct(pairs: &[(f64, f64)]) -> f64 {
    let (y, yhat): (Vec<f64>, Vec<f64>) = pairs.iter().copied().unzip();
    model_core::metrics::metrics(&y, &yhat).map_or(f64::NAN, |m| m.fit_pct)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_pct_of_a_perfect_and_a_mean_model() {
        let y = [1.0, 2.0, 3.0];
        assert_eq!(fit_pct(&y.map(|v| (v, v))), 100.0);
        assert!(fit_pct(&y.map(|v| (v, 2.0))).abs() < 1e-12);
    }
}
