//! Weighted grey correlativity (seed 002, Eq. 1): grey relational analysis
//! that weighs the distance between the sequences and the distance between
//! their rates of change.
//!
//! For the target `x_0` (a displacement) and each input `x_i` (a
//! temperature), both made dimensionless first (see below):
//!
//! ```text
//! x'(k)   = x(k) - x(k-1)                                   (difference sequence)
//! D_i(k)  = |x_0(k) - x_i(k)|,   D'_i(k) = |x'_0(k) - x'_i(k)|
//! D_max   = max_i max_k D_i(k)
//! zeta_i(k) = xi D_max / (lambda1 D_i(k) + lambda2 D'_i(k) + xi D_max)
//! gamma_i   = mean_k zeta_i(k)
//! ```
//!
//! with the distinguishing coefficient `xi = 0.5` and the displacement and
//! rate weights `lambda1 = lambda2 = 0.5` (seed 002 after Eq. 1). Unlike
//! Deng's coefficient there is no `D_min` term, and only the displacement
//! term's maximum scales the coefficient.
//!
//! `k` runs over the samples that have a predecessor in the same run: Eq. 1
//! sums `k = 1..90` with `x'(k) = x(k) - x(k-1)`, so `x(0)` is the sample
//! before the first term. `D_max` is taken over the same samples, and a new
//! run starts a new difference sequence (its first sample is only a
//! predecessor).
//!
//! # Why dimensionless first
//!
//! `D_i(k)` subtracts a displacement (um, or mm in seed 002) from a
//! temperature (deg C). On raw values the coefficient would measure which
//! temperature happens to sit numerically closest to the displacement, and
//! would change with the units. The caller applies one of the processings of
//! [`super::grey::dimensionless`] to every sequence first (initial-value
//! processing by default, as grey relational analysis usually does); the
//! ranking is then about the shape of the curves.

/// Coefficients of Eq. 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    /// Distinguishing coefficient `xi` (0.5 in seed 002).
    pub xi: f64,
    /// Weight of the displacement term `lambda1` (0.5 in seed 002).
    pub lambda1: f64,
    /// Weight of the rate-of-change term `lambda2` (0.5 in seed 002).
    pub lambda2: f64,
}

impl Default for Weights {
    fn default() -> Self {
        Weights {
            xi: 0.5,
            lambda1: 0.5,
            lambda2: 0.5,
        }
    }
}

/// Why Eq. 1 cannot be evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum WgreyError {
    /// No run has two samples, so there is no difference sequence.
    NoDifferences,
    /// `D_max = 0`: every input equals the target at every sample.
    Identical,
}

impl std::fmt::Display for WgreyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WgreyError::NoDifferences => {
                f.write_str("no run has two samples: Eq. 1 needs a difference sequence")
            }
            WgreyError::Identical => f.write_str(
                "every input equals the target after processing: the correlativity is undefined",
            ),
        }
    }
}

impl std::error::Error for WgreyError {}

/// `gamma_i` of every column with `target` (module docs). The sequences are
/// dimensionless already and concatenated over runs of lengths `runs`.
pub fn gammas(
    target: &[f64],
    cols: &[Vec<f64>],
    runs: &[usize],
    w: &Weights,
) -> Result<Vec<f64>, WgreyError> {
    // (k, k-1) pairs within each run.
    let mut pairs = Vec::with_capacity(target.len());
    let mut start = 0;
    for &len in runs {
        pairs.extend((start + 1..start + len).map(|k| (k, k - 1)));
        start += len;
    }
    if pairs.is_empty() {
        return Err(WgreyError::NoDifferences);
    }
    let d_max = cols
        .iter()
        .flat_map(|c| pairs.iter().map(move |&(k, _)| (target[k] - c[k]).abs()))
        .fold(0.0, f64::max);
    if d_max == 0.0 {
        return Err(WgreyError::Identical);
    }
    let num = w.xi * d_max;
    Ok(cols
        .iter()
        .map(|c| {
            let sum: f64 = pairs
                .iter()
                .map(|&(k, j)| {
                    let d = (target[k] - c[k]).abs();
                    let dd = ((target[k] - target[j]) - (c[k] - c[j])).abs();
                    num / (w.lambda1 * d + w.lambda2 * dd + num)
                })
                .sum();
            sum / pairs.len() as f64
        })
        .collect())
}

/// Indices of the `k` largest values, largest first (the lower index first
/// on ties).
pub fn top_k(values: &[f64], k: usize) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..values.len()).collect();
    idx.sort_by(|&a, &b| values[b].total_cmp(&values[a]).then(a.cmp(&b)));
    idx.truncate(k);
    idx
}

/// The indices present in every set, ascending (seed 002 kept the points in
/// both targets' top six).
pub fn intersection(sets: &[Vec<usize>]) -> Vec<usize> {
    let Some((first, rest)) = sets.split_first() else {
        return Vec::new();
    };
    let mut out: Vec<usize> = first
        .iter()
        .copied()
        .filter(|i| rest.iter().all(|s| s.contains(i)))
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq1_by_hand() {
        // x0 = (1, 2, 3), x1 = (1, 1, 1), x2 = (1, 2, 2), one run; k = 2, 3.
        // D1 = (1, 2), D1' = (1, 1); D2 = (0, 1), D2' = (0, 1); D_max = 2,
        // xi D_max = 1. zeta1 = 1/(0.5 + 0.5 + 1), 1/(1 + 0.5 + 1) -> 0.45;
        // zeta2 = 1/1, 1/(0.5 + 0.5 + 1) -> 0.75. Tolerance: two roundings.
        let g = gammas(
            &[1.0, 2.0, 3.0],
            &[vec![1.0, 1.0, 1.0], vec![1.0, 2.0, 2.0]],
            &[3],
            &Weights::default(),
        )
        .unwrap();
        assert!(
            (g[0] - 0.45).abs() < 1e-15 && (g[1] - 0.75).abs() < 1e-15,
            "{g:?}"
        );
    }

    #[test]
    fn runs_do_not_difference_across_their_boundary() {
        // Two runs of (1, 2): the jump 2 -> 1 between them is no step.
        // x1 = (1, 1, 5, 5): D = (1, 3) at the second samples, D' = (1, 1);
        // D_max = 3, xi D_max = 1.5: zeta = 1.5/(0.5 + 0.5 + 1.5),
        // 1.5/(1.5 + 0.5 + 1.5).
        let g = gammas(
            &[1.0, 2.0, 1.0, 2.0],
            &[vec![1.0, 1.0, 5.0, 5.0]],
            &[2, 2],
            &Weights::default(),
        )
        .unwrap();
        let want = (1.5 / 2.5 + 1.5 / 3.5) / 2.0;
        assert!((g[0] - want).abs() < 1e-15);
        assert_eq!(
            gammas(&[1.0, 2.0], &[vec![1.0, 2.0]], &[1, 1], &Weights::default()),
            Err(WgreyError::NoDifferences)
        );
        assert_eq!(
            gammas(&[1.0, 2.0], &[vec![1.0, 2.0]], &[2], &Weights::default()),
            Err(WgreyError::Identical)
        );
    }

    #[test]
    fn ranking_and_intersection() {
        assert_eq!(top_k(&[0.2, 0.9, 0.5, 0.9], 3), vec![1, 3, 2]);
        assert_eq!(top_k(&[0.2], 6), vec![0]);
        // Seed 002: top six of x0 and of x17 share points 3, 4, 10, 12
        // (1-based), listed here 0-based as the paper ranked them.
        let x0 = vec![2, 11, 3, 8, 13, 9];
        let x17 = vec![6, 9, 3, 12, 11, 2];
        assert_eq!(intersection(&[x0, x17]), vec![2, 3, 9, 11]);
    }
}
