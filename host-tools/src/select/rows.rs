//! The rows a selection computes on, and their dimensionless processing:
//! [`Table`] lines up the rows where every needed column has a value,
//! [`ScaleChoice`] settles the processing of one grey computation
//! (with `--scale initial`'s fallback, [`INITIAL_FALLBACK`]).

use super::grey;
use super::outcome::ScaleFallback;
use crate::data::cells::Cells;
use crate::data::runfile::RunFile;
use crate::num::stats;
use anyhow::{anyhow, bail, Result};

/// The rows of the runs where every one of some columns has a value.
pub(super) struct Table {
    /// One vector per column, the runs' kept rows concatenated.
    pub(super) cols: Vec<Vec<f64>>,
    /// Kept rows per run.
    pub(super) runs: Vec<usize>,
    /// Rows left out per run.
    pub(super) left_out: Vec<usize>,
}

impl Table {
    /// The rows of `files` where every column `names` has a value.
    pub(super) fn new(files: &[RunFile], names: &[&str]) -> Table {
        let mut cols = vec![Vec::new(); names.len()];
        let mut runs = Vec::with_capacity(files.len());
        let mut left_out = Vec::with_capacity(files.len());
        for f in files {
            let src: Vec<Cells<'_>> = names
                .iter()
                .map(|n| f.column(n).unwrap_or_default())
                .collect();
            let (mut kept, mut out) = (0usize, 0usize);
            for row in 0..f.len() {
                let vals: Option<Vec<f64>> = src.iter().map(|c| c.get(row)).collect();
                match vals {
                    Some(v) => {
                        for (col, x) in cols.iter_mut().zip(v) {
                            col.push(x);
                        }
                        kept += 1;
                    }
                    None => out += 1,
                }
            }
            runs.push(kept);
            left_out.push(out);
        }
        Table {
            cols,
            runs,
            left_out,
        }
    }

    /// Rows kept, over all runs.
    pub(super) fn rows(&self) -> usize {
        self.runs.iter().sum()
    }

    /// Reports left-out rows on stderr; fails when too few rows remain.
    pub(super) fn report(&self, files: &[RunFile], what: &str, min_rows: usize) -> Result<()> {
        for (f, &out) in files.iter().zip(&self.left_out) {
            if out > 0 {
                eprintln!(
                    "note: {}: {out} of {} rows lack {what}: left out",
                    f.path.display(),
                    f.len()
                );
            }
        }
        if self.rows() < min_rows {
            bail!(
                "only {} rows have {what}: at least {min_rows} are needed",
                self.rows()
            );
        }
        Ok(())
    }
}

/// The columns `names` plus `target`, on the rows where all have values.
pub(super) fn with_target<'a>(names: &[&'a str], target: &'a str) -> Vec<&'a str> {
    let mut v = names.to_vec();
    v.push(target);
    v
}

/// Applies the dimensionless processing, naming the column on failure.
pub(super) fn scaled(
    col: &[f64],
    runs: &[usize],
    scale: grey::Scale,
    name: &str,
) -> Result<Vec<f64>> {
    grey::dimensionless(col, runs, scale).map_err(|e| {
        // The scales that do not divide by what was zero here: a run
        // starting at 0 may still have a mean and a range; one whose mean
        // is 0 a range; a constant one none (raw values only).
        let others: &[&str] = match e {
            grey::ScaleError::ZeroInitial { .. } => &["mean", "interval", "none"],
            grey::ScaleError::ZeroMean { .. } => &["interval", "none"],
            _ => &["none"],
        };
        anyhow!(
            "{name}: {e} (--scale {}); choose another --scale: {}",
            scale.name(),
            others.join(", ")
        )
    })
}

/// What `--scale initial` falls back to in a grey computation where a series
/// starts at exactly 0 (docs/select.md, "Zero starts"). Interval processing
/// is defined for every series that is not constant, and for a series that
/// starts at its minimum, as a zeroed displacement usually does, it is
/// `(x(k) - x(1)) / range`: like the initial-value image `x(k)/x(1) - 1`, the
/// change since the start, only scaled by the range instead of `x(1)`.
/// (Mean processing would also be defined, but it flattens temperatures to
/// within a few percent of 1, and the grey coefficients with it.)
pub const INITIAL_FALLBACK: grey::Scale = grey::Scale::Interval;

/// The processing one grey computation uses: the requested one, or
/// [`INITIAL_FALLBACK`] for every series of the computation when the
/// request is initial-value processing and some series starts at 0 (grey
/// coefficients compare the series point by point, so all of them take the
/// same processing).
pub(super) struct ScaleChoice {
    /// The processing asked for.
    pub(super) requested: grey::Scale,
    /// The processing used.
    pub(super) used: grey::Scale,
    /// The series that start at 0, with the first such run (1-based).
    zero_start: Vec<(String, usize)>,
    /// Every series of the computation (all use `used`).
    series: Vec<String>,
}

impl ScaleChoice {
    /// The processing of the computation over `series` (runs of `runs` rows).
    pub(super) fn new(requested: grey::Scale, series: &[(&str, &[f64])], runs: &[usize]) -> Self {
        let zero_start: Vec<(String, usize)> = if requested == grey::Scale::Initial {
            series
                .iter()
                .filter_map(|(n, c)| grey::zero_start_run(c, runs).map(|r| (n.to_string(), r + 1)))
                .collect()
        } else {
            Vec::new()
        };
        let used = if zero_start.is_empty() {
            requested
        } else {
            INITIAL_FALLBACK
        };
        Self {
            requested,
            used,
            zero_start,
            series: series.iter().map(|(n, _)| n.to_string()).collect(),
        }
    }

    /// Some series started at 0 and all took [`INITIAL_FALLBACK`].
    fn fell_back(&self) -> bool {
        !self.zero_start.is_empty()
    }

    /// `None`, or which series started at 0 and which took the fallback.
    pub(super) fn fallback(&self) -> Option<ScaleFallback> {
        if !self.fell_back() {
            return None;
        }
        Some(ScaleFallback {
            from: self.requested.name(),
            to: self.used.name(),
            zero_start: self.zero_start.iter().map(|(n, _)| n.clone()).collect(),
            series: self.series.clone(),
        })
    }

    /// Says on stderr that `what` fell back, and why.
    pub(super) fn note(&self, what: &str) {
        if let Some(line) = self.text(what) {
            eprintln!("note: {line}");
        }
    }

    /// One line on the fallback, if there was one.
    pub(super) fn text(&self, what: &str) -> Option<String> {
        if !self.fell_back() {
            return None;
        }
        let starts: Vec<String> = self
            .zero_start
            .iter()
            .map(|(n, r)| format!("{n} (run {r})"))
            .collect();
        Some(format!(
            "{} start(s) at 0, where {} processing x(k)/x(1) is undefined: {what} uses {} processing for all {} series instead (docs/select.md, zero starts)",
            starts.join(", "),
            self.requested.name(),
            self.used.name(),
            self.series.len()
        ))
    }
}

/// The `(name, column)` pairs of a table's columns.
pub(super) fn series<'a>(names: &[&'a str], cols: &'a [Vec<f64>]) -> Vec<(&'a str, &'a [f64])> {
    names
        .iter()
        .zip(cols)
        .map(|(n, c)| (*n, c.as_slice()))
        .collect()
}

/// Initial-value processing divides by the first sample; a displacement
/// that starts near zero (the usual case: it is zeroed at the start) is then
/// mostly its noise blown up. Warns when the first value is under this
/// fraction of the run's range.
const SMALL_INITIAL: f64 = 0.05;

/// The dimensionless target, with a note when initial-value processing
/// divides by a value close to zero.
pub(super) fn scaled_target(
    col: &[f64],
    runs: &[usize],
    scale: grey::Scale,
    name: &str,
) -> Result<Vec<f64>> {
    if scale == grey::Scale::Initial {
        let mut start = 0;
        for (i, &len) in runs.iter().enumerate() {
            let seg = &col[start..start + len];
            start += len;
            let (lo, hi) = seg
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(*v), hi.max(*v))
                });
            if let Some(&x1) = seg.first() {
                if x1 != 0.0 && x1.abs() < SMALL_INITIAL * (hi - lo) {
                    eprintln!(
                        "note: {name} starts at {x1} in run {}, {:.1}% of its range: initial-value processing divides by it, so the noise at the start sets the scale; --scale interval compares the curves' shapes instead",
                        i + 1,
                        100.0 * x1.abs() / (hi - lo)
                    );
                }
            }
        }
    }
    scaled(col, runs, scale, name)
}

/// Pearson r of each column with the target, failing on a constant one.
pub(super) fn target_correlations(t: &Table, names: &[&str], target: &str) -> Result<Vec<f64>> {
    let y = t.cols.last().map(Vec::as_slice).unwrap_or(&[]);
    if stats::pearson(y, y).is_none() {
        bail!(
            "{target} is constant over the {} rows used: there is nothing to explain",
            t.rows()
        );
    }
    names
        .iter()
        .zip(&t.cols)
        .map(|(n, c)| {
            stats::pearson(c, y).ok_or_else(|| {
                anyhow!(
                    "{n} is constant over the {} rows used: its correlation is undefined; leave it out with --inputs",
                    t.rows()
                )
            })
        })
        .collect()
}

/// The names of the columns `idx`.
pub(super) fn names_of(idx: &[usize], names: &[&str]) -> Vec<String> {
    idx.iter().map(|&i| names[i].to_string()).collect()
}

/// Each input column of `t` (the first `names.len()`) in the processing
/// `scale`, naming the column on failure.
pub(super) fn scaled_inputs(
    t: &Table,
    names: &[&str],
    scale: grey::Scale,
) -> Result<Vec<Vec<f64>>> {
    names
        .iter()
        .zip(&t.cols)
        .map(|(n, c)| scaled(c, &t.runs, scale, n))
        .collect()
}
