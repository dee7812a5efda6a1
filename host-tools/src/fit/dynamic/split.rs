//! How an order search scores a candidate on calibration samples only:
//! the search-validation tail of each run (`--search-holdout`) or blocked
//! cross-validation over contiguous folds (`--search-folds`). The held-out
//! rows of a fit (`--holdout-from-s`) are never seen by the search.

use anyhow::{bail, Result};
use serde::Serialize;

/// First sample of the search-validation segment of a run with `calib_end`
/// calibration samples (the last `h` of them).
pub fn search_split(calib_end: usize, h: f64) -> usize {
    // Truncation is intended: a whole number of samples.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let n_val = ((calib_end as f64) * h).round() as usize;
    calib_end - n_val.min(calib_end)
}

/// Most folds `--search-folds` takes (one bit each in a row's exclusion mask).
pub const MAX_FOLDS: usize = 64;

/// How the order search scores a candidate, on calibration samples only.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SearchScheme {
    /// Blocked cross-validation: each run's calibration samples cut into
    /// this many contiguous folds; fold `j` of every run is held out at once.
    Folds(usize),
    /// One held-out segment: the last fraction of each run's calibration samples.
    Tail(f64),
}

impl SearchScheme {
    /// From `--search-folds` and `--search-holdout`.
    pub fn new(search_folds: usize, search_holdout: f64) -> Result<Self> {
        match search_folds {
            0 => bail!("--search-folds 0: at least 1"),
            1 => {
                check_holdout(search_holdout)?;
                Ok(Self::Tail(search_holdout))
            }
            k if k > MAX_FOLDS => bail!("--search-folds {k}: at most {MAX_FOLDS}"),
            k => Ok(Self::Folds(k)),
        }
    }

    /// Number of held-out segments per run.
    pub fn count(self) -> usize {
        match self {
            Self::Folds(k) => k,
            Self::Tail(_) => 1,
        }
    }

    /// Held-out samples `[from, to)` of segment `j` of a run with
    /// `calib_end` calibration samples.
    pub fn segment(self, calib_end: usize, j: usize) -> (usize, usize) {
        match self {
            Self::Folds(k) => (calib_end * j / k, calib_end * (j + 1) / k),
            Self::Tail(h) => (search_split(calib_end, h), calib_end),
        }
    }

    /// Bit `j` set when segment `j` excludes sample `k` from estimation: `k`
    /// is in the segment or its regressors (`lag` samples back) reach into it.
    pub fn excluded_by(self, calib_end: usize, k: usize, lag: usize) -> u64 {
        (0..self.count()).fold(0, |mask, j| {
            let (from, to) = self.segment(calib_end, j);
            if (from..to + lag).contains(&k) {
                mask | 1 << j
            } else {
                mask
            }
        })
    }

    /// What the search scored on, for the report.
    pub fn report(self) -> SchemeReport {
        match self {
            Self::Folds(k) => SchemeReport {
                folds: Some(k),
                scheme: "blocked cross-validation",
                score: "simulation fit % (free run from each run's start) pooled over the held-out folds; each fold's model estimated on the other calibration samples (regression rows whose lags reach into the fold excluded too)",
                search_holdout: None,
            },
            Self::Tail(h) => SchemeReport {
                folds: None,
                scheme: "tail",
                score: "simulation fit % (free run from each run's start) on the last search_holdout of each run's calibration samples",
                search_holdout: Some(h),
            },
        }
    }
}

/// A [`SearchScheme`] as reported (fields in the JSON's key order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SchemeReport {
    /// Cross-validation folds per run (blocked cross-validation only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub folds: Option<usize>,
    /// `blocked cross-validation` or `tail`.
    pub scheme: &'static str,
    /// What the search's score is.
    pub score: &'static str,
    /// Fraction of each run's calibration samples held out (tail only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub search_holdout: Option<f64>,
}

/// Checks `--search-holdout`.
pub fn check_holdout(h: f64) -> Result<()> {
    if !(h > 0.0 && h < 1.0) {
        bail!("--search-holdout {h} must be in (0, 1)");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folds_partition_the_calibration_samples() {
        // Every calibration sample is held out exactly once, in contiguous
        // folds of near-equal length (uneven counts included).
        for (n, k) in [(5760, 4), (10, 3), (7, 7), (3, 4)] {
            let s = SearchScheme::Folds(k);
            let segs: Vec<(usize, usize)> = (0..s.count()).map(|j| s.segment(n, j)).collect();
            assert_eq!(segs[0].0, 0);
            assert_eq!(segs[k - 1].1, n);
            for w in segs.windows(2) {
                assert_eq!(w[0].1, w[1].0);
            }
            for (a, b) in &segs {
                assert!(b - a <= n.div_ceil(k), "{n} {k}: fold {a}..{b}");
            }
        }
        let tail = SearchScheme::Tail(0.25);
        assert_eq!(tail.count(), 1);
        assert_eq!(tail.segment(100, 0), (75, 100));
    }

    #[test]
    fn each_scheme_reports_its_own_keys() {
        let keys = |s: SearchScheme| {
            let v = serde_json::to_value(s.report()).unwrap();
            v.as_object().unwrap().keys().cloned().collect::<Vec<_>>()
        };
        assert_eq!(keys(SearchScheme::Folds(4)), ["folds", "scheme", "score"]);
        assert_eq!(
            keys(SearchScheme::Tail(0.25)),
            ["scheme", "score", "search_holdout"]
        );
    }
}
