//! The score the order searches and input selection rank by: the
//! system-identification fit % of a free-run simulation against the
//! measured target (seed 004, Eq. 4).

/// System-identification fit % of `yhat` against `y` (seed 004, Eq. 4).
pub fn fit_pct(pairs: &[(f64, f64)]) -> f64 {
    let n = pairs.len() as f64;
    if pairs.is_empty() {
        return f64::NAN;
    }
    let mean = pairs.iter().map(|p| p.0).sum::<f64>() / n;
    let sse: f64 = pairs.iter().map(|(y, h)| (y - h).powi(2)).sum();
    let sst: f64 = pairs.iter().map(|(y, _)| (y - mean).powi(2)).sum();
    if sst == 0.0 {
        return if sse == 0.0 { 100.0 } else { 0.0 };
    }
    (1.0 - (sse / sst).sqrt()) * 100.0
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
