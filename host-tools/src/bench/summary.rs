//! The summary of a set of diagnosed cases: confusion matrix (true cause x
//! verdict), accuracy, false alarms, wrong effects, misses and the held-out
//! shrink of the correctly identified cases.

use super::cases::LABELS;
use super::outcome::{Diagnosis, Outcome};
use crate::diagnose::candidates::round;
use serde::Serialize;
use std::collections::BTreeMap;

/// The summary of a benchmark.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Number of cases.
    pub cases: usize,
    /// `confusion[i][j]`: cases of true cause `LABELS[i]` with verdict `LABELS[j]`.
    pub confusion: [[usize; 6]; 6],
    /// Share of all cases whose verdict is the true cause, %.
    pub accuracy_pct: f64,
    /// Share of the effect cases (not `none`) identified, %.
    pub effect_accuracy_pct: f64,
    /// `none` cases given an effect, and all `none` cases.
    pub false_alarms: (usize, usize),
    /// Effect cases given `none`.
    pub misses: usize,
    /// Effect cases given another effect.
    pub wrong_effect: usize,
    /// Effect cases.
    pub effect_cases: usize,
    /// Cases where a second effect was claimed (every case has one cause).
    pub spurious_seconds: usize,
    /// Median held-out shrink of the correctly identified effect cases, %.
    pub median_shrink_correct_pct: f64,
    /// Per cause: (n correct, min, median, max shrink of the correct ones).
    pub shrink_by_effect: Vec<(String, usize, f64, f64, f64)>,
}

impl Summary {
    /// False alarms over `none` cases, %.
    pub fn false_alarm_rate_pct(&self) -> f64 {
        pct(self.false_alarms.0, self.false_alarms.1)
    }

    /// Effect cases given a wrong effect over all effect cases, %.
    pub fn wrong_effect_rate_pct(&self) -> f64 {
        pct(self.wrong_effect, self.effect_cases)
    }

    /// Effect cases given `none` over all effect cases, %.
    pub fn miss_rate_pct(&self) -> f64 {
        pct(self.misses, self.effect_cases)
    }
}

/// `100 a / b`, NaN when `b` is 0.
pub fn pct(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        100.0 * a as f64 / b as f64
    }
}

/// Median of the finite values of `x` (NaN when there are none).
pub fn median(x: &[f64]) -> f64 {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    crate::num::stats::median(&mut v).unwrap_or(f64::NAN)
}

fn label_index(l: &str) -> usize {
    LABELS
        .iter()
        .position(|x| *x == l)
        .unwrap_or(LABELS.len() - 1)
}

/// Confusion matrix, rates and shrink distributions of `outs`.
pub fn summarise<C>(outs: &[Outcome<C>]) -> Summary {
    let d: Vec<&Diagnosis> = outs.iter().map(|o| &o.diag).collect();
    summarise_diagnoses(&d)
}

/// Per cause: (n, min, median, max) of the verdict shrinks of `correct`.
fn shrinks_by_effect(correct: &[&&Diagnosis]) -> Vec<(String, usize, f64, f64, f64)> {
    LABELS[..5]
        .iter()
        .map(|l| {
            let s: Vec<f64> = correct
                .iter()
                .filter(|d| d.truth == *l)
                .map(|d| d.verdict_shrink_pct)
                .collect();
            let lo = s.iter().copied().fold(f64::NAN, f64::min);
            let hi = s.iter().copied().fold(f64::NAN, f64::max);
            (l.to_string(), s.len(), lo, median(&s), hi)
        })
        .collect()
}

/// Confusion matrix, rates and shrink distributions of diagnoses.
pub fn summarise_diagnoses(d: &[&Diagnosis]) -> Summary {
    let mut confusion = [[0usize; 6]; 6];
    for o in d {
        confusion[label_index(&o.truth)][label_index(&o.verdict)] += 1;
    }
    let effect_cases: Vec<&&Diagnosis> = d.iter().filter(|o| o.truth != "none").collect();
    let none_cases = d.len() - effect_cases.len();
    let effect_correct: Vec<&&Diagnosis> = effect_cases
        .iter()
        .copied()
        .filter(|o| o.correct())
        .collect();
    let shrinks: Vec<f64> = effect_correct
        .iter()
        .map(|o| o.verdict_shrink_pct)
        .collect();
    Summary {
        cases: d.len(),
        confusion,
        accuracy_pct: pct(d.iter().filter(|o| o.correct()).count(), d.len()),
        effect_accuracy_pct: pct(effect_correct.len(), effect_cases.len()),
        false_alarms: (
            d.iter()
                .filter(|o| o.truth == "none" && o.verdict != "none")
                .count(),
            none_cases,
        ),
        misses: effect_cases.iter().filter(|o| o.verdict == "none").count(),
        wrong_effect: effect_cases
            .iter()
            .filter(|o| o.verdict != "none" && !o.correct())
            .count(),
        effect_cases: effect_cases.len(),
        spurious_seconds: d.iter().filter(|o| o.second.is_some()).count(),
        median_shrink_correct_pct: median(&shrinks),
        shrink_by_effect: shrinks_by_effect(&effect_correct),
    }
}

/// A confusion matrix as reported: rows keyed by true cause, columns by
/// verdict.
pub type Confusion = BTreeMap<String, BTreeMap<String, usize>>;

/// The confusion matrix of `s`, keyed by label.
pub fn confusion(s: &Summary) -> Confusion {
    LABELS
        .iter()
        .zip(&s.confusion)
        .map(|(l, row)| {
            let row = LABELS
                .iter()
                .map(|v| v.to_string())
                .zip(row.iter().copied());
            (l.to_string(), row.collect())
        })
        .collect()
}

/// The held-out shrinks of one cause's correctly identified cases.
#[derive(Debug, Clone, Serialize)]
pub struct ShrinkReport {
    /// Correct cases.
    pub n_correct: usize,
    /// Smallest shrink, %.
    pub min_pct: Option<f64>,
    /// Median shrink, %.
    pub median_pct: Option<f64>,
    /// Largest shrink, %.
    pub max_pct: Option<f64>,
}

/// A [`Summary`] as reported (`bench gap --twin --json`, `summary.json`).
#[derive(Debug, Clone, Serialize)]
pub struct SummaryReport {
    /// The causes, in the matrix's order.
    pub labels: [&'static str; 6],
    /// True cause x verdict.
    pub confusion: Confusion,
    /// Share of all cases right, %.
    pub accuracy_pct: Option<f64>,
    /// Share of the effect cases right, %.
    pub effect_accuracy_pct: Option<f64>,
    /// `none` cases given an effect.
    pub false_alarms: usize,
    /// `none` cases.
    pub none_cases: usize,
    /// False alarms over `none` cases, %.
    pub false_alarm_rate_pct: Option<f64>,
    /// Effect cases given `none`.
    pub misses: usize,
    /// Effect cases given another effect.
    pub wrong_effect: usize,
    /// Cases where a second effect was claimed.
    pub spurious_seconds: usize,
    /// Median held-out shrink of the correct effect cases, %.
    pub median_shrink_correct_pct: Option<f64>,
    /// Per cause, the shrinks of its correct cases.
    pub shrink_correct_by_effect: BTreeMap<String, ShrinkReport>,
}

impl SummaryReport {
    /// The report of `s` (numbers rounded, undefined ones null).
    pub fn of(s: &Summary) -> Self {
        let by_effect = s
            .shrink_by_effect
            .iter()
            .map(|(l, n, lo, med, hi)| {
                let r = ShrinkReport {
                    n_correct: *n,
                    min_pct: fin(*lo),
                    median_pct: fin(*med),
                    max_pct: fin(*hi),
                };
                (l.clone(), r)
            })
            .collect();
        Self {
            labels: LABELS,
            confusion: confusion(s),
            accuracy_pct: fin(s.accuracy_pct),
            effect_accuracy_pct: fin(s.effect_accuracy_pct),
            false_alarms: s.false_alarms.0,
            none_cases: s.false_alarms.1,
            false_alarm_rate_pct: fin(s.false_alarm_rate_pct()),
            misses: s.misses,
            wrong_effect: s.wrong_effect,
            spurious_seconds: s.spurious_seconds,
            median_shrink_correct_pct: fin(s.median_shrink_correct_pct),
            shrink_correct_by_effect: by_effect,
        }
    }
}

/// A finite number rounded, or null (JSON has no NaN).
pub fn fin(v: f64) -> Option<f64> {
    v.is_finite().then(|| round(v))
}
