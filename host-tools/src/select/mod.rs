//! `thermcomp select`: picks the temperature sensors a thermal-error model
//! should use (CONTRACT.md section 1), by one of three methods from the
//! seed papers:
//!
//! - `grey` (seed 000, [`grey`]): grey comprehensive correlation degrees
//!   between the temperatures group them (grey clustering at `--level`); the
//!   variable of each group with the largest grey (Deng) correlation with
//!   the error is its typical variable; every combination of the typical
//!   variables is regressed on the error, and the combination with the best
//!   adjusted R^2 is selected.
//! - `wgrey` (seed 002 Eq. 1, [`wgrey`]): weighted grey correlativity of each
//!   temperature with each target; the `--top` best per target, and with
//!   several targets the sensors in every target's top set.
//! - `maxtree` (seed 003, [`maxtree`]): maximal-tree fuzzy clustering of the
//!   temperatures by |Pearson r|, one level per distinct edge weight, the
//!   representative of each group by |r| with the target, and the level
//!   chosen by R^2 and the regression's F test, guarded against
//!   collinearity.
//!
//! This module reads the runs, lines up the rows, calls the pure functions
//! of the method modules and prints the result (one JSON object with
//! `--json`). Rows where a needed value is missing are left out of that
//! computation and counted on stderr. With `--scale initial`, a grey
//! computation in which a series starts at 0 uses interval processing for
//! all its series, and says so ([`INITIAL_FALLBACK`]). docs/select.md has
//! the formulas and their sources.

pub mod grey;
pub mod maxtree;
pub mod wgrey;

use crate::data::runfile::{ReadOptions, RunFile};
use crate::num::stats;
use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, ValueEnum};
use serde::Serialize;
use serde_json::{json, Map, Value};
use std::path::PathBuf;

/// Largest number of typical variables `grey` combines: 2^12 - 1 = 4095
/// regressions. Past that the table is unreadable and the choice among
/// thousands of near-equal fits means nothing.
pub const MAX_TYPICAL: usize = 12;

/// Selection methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Grey clustering + grey correlation + combinations (seed 000).
    Grey,
    /// Weighted grey correlativity, top-k per target (seed 002 Eq. 1).
    Wgrey,
    /// Maximal-tree fuzzy clustering + regression (seed 003).
    Maxtree,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Grey => "grey",
            Method::Wgrey => "wgrey",
            Method::Maxtree => "maxtree",
        }
    }
}

/// Dimensionless processing before grey correlation with the target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ScaleArg {
    /// x(k) / x(1), per run (interval processing for a computation in which
    /// a series starts at 0).
    Initial,
    /// x(k) / mean(x), per run.
    Mean,
    /// (x(k) - min) / (max - min), per run.
    Interval,
    /// Raw values (only sensible when target and inputs share a unit).
    None,
}

impl From<ScaleArg> for grey::Scale {
    fn from(s: ScaleArg) -> Self {
        match s {
            ScaleArg::Initial => grey::Scale::Initial,
            ScaleArg::Mean => grey::Scale::Mean,
            ScaleArg::Interval => grey::Scale::Interval,
            ScaleArg::None => grey::Scale::None,
        }
    }
}

/// Arguments of `thermcomp select`.
#[derive(Args, Debug)]
pub struct SelectArgs {
    /// A run file (CSV); repeatable. Runs are concatenated for correlations;
    /// differences, initial values and zero-start images restart per run.
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// Target column(s), comma-separated (e.g. ch1_um). grey and maxtree take one.
    #[arg(long, value_delimiter = ',', required = true)]
    pub target: Vec<String>,
    /// Candidate input columns, comma-separated (default: every column named
    /// T<number> in the first run, in file order).
    #[arg(long, value_delimiter = ',')]
    pub inputs: Vec<String>,
    /// Selection method.
    #[arg(long, value_enum)]
    pub method: Method,
    /// Print one JSON object instead of tables.
    #[arg(long)]
    pub json: bool,
    /// Skip rows with unparsable cells instead of failing (counted and reported).
    #[arg(long)]
    pub skip_bad_rows: bool,

    /// Dimensionless processing of target and inputs before grey correlation
    /// with the target (grey, wgrey): temperature and displacement have
    /// different units. With `initial`, a computation in which the target or
    /// an input starts at exactly 0 (x(1) = 0 in some run) uses interval
    /// processing for all its series instead, and says so.
    #[arg(
        long,
        value_enum,
        default_value = "initial",
        help_heading = "grey and wgrey"
    )]
    pub scale: ScaleArg,
    /// Distinguishing coefficient xi of the grey correlation coefficient.
    #[arg(long, default_value_t = 0.5, help_heading = "grey and wgrey")]
    pub xi: f64,

    /// Weight theta of the absolute degree in the comprehensive degree
    /// (rho = theta * absolute + (1 - theta) * relative).
    #[arg(long, default_value_t = 0.5, help_heading = "grey")]
    pub theta: f64,
    /// Grey clustering level: variables whose comprehensive degree is at
    /// least this are joined (seed 000 used 0.9).
    #[arg(long, default_value_t = 0.9, help_heading = "grey")]
    pub level: f64,

    /// Weight lambda1 of the displacement term of seed 002 Eq. 1.
    #[arg(long, default_value_t = 0.5, help_heading = "wgrey")]
    pub lambda1: f64,
    /// Weight lambda2 of the rate-of-change term of seed 002 Eq. 1.
    #[arg(long, default_value_t = 0.5, help_heading = "wgrey")]
    pub lambda2: f64,
    /// How many of the best inputs to keep per target (seed 002 kept 6).
    #[arg(long, default_value_t = 6, help_heading = "wgrey")]
    pub top: usize,

    /// Significance level of the regression F test.
    #[arg(long, default_value_t = 0.05, help_heading = "maxtree")]
    pub alpha: f64,
    /// A larger set of representatives must raise R^2 by at least this much
    /// over the smallest adequate one (0 = seed 003's rule: the best R^2).
    #[arg(long, default_value_t = 0.01, help_heading = "maxtree")]
    pub min_gain: f64,
    /// Levels with a representative whose tolerance 1/VIF is below this are
    /// left out (SPSS's default tolerance, 0.0001).
    #[arg(long, default_value_t = 1e-4, help_heading = "maxtree")]
    pub min_tolerance: f64,
}

impl SelectArgs {
    fn check(&self) -> Result<()> {
        let unit = |name: &str, v: f64| -> Result<()> {
            if !(0.0..=1.0).contains(&v) {
                bail!("--{name} {v}: must lie in [0, 1]");
            }
            Ok(())
        };
        if !(self.xi > 0.0 && self.xi <= 1.0) {
            bail!("--xi {}: must lie in (0, 1]", self.xi);
        }
        unit("theta", self.theta)?;
        unit("level", self.level)?;
        unit("min-tolerance", self.min_tolerance)?;
        for (name, v) in [("lambda1", self.lambda1), ("lambda2", self.lambda2)] {
            if !(v.is_finite() && v >= 0.0) {
                bail!("--{name} {v}: must be a finite number >= 0");
            }
        }
        if self.lambda1 + self.lambda2 <= 0.0 {
            bail!("--lambda1 and --lambda2 are both 0: Eq. 1 would weigh nothing");
        }
        if self.top == 0 {
            bail!("--top 0: keep at least one input");
        }
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            bail!("--alpha {}: must lie in (0, 1)", self.alpha);
        }
        if !(self.min_gain.is_finite() && self.min_gain >= 0.0) {
            bail!("--min-gain {}: must be a finite number >= 0", self.min_gain);
        }
        if self.method != Method::Wgrey && self.target.len() != 1 {
            bail!(
                "--method {} takes one --target column (got {}); run it once per target, or use --method wgrey",
                self.method.name(),
                self.target.len()
            );
        }
        for t in &self.target {
            if t.trim().is_empty() {
                bail!("--target: empty column name");
            }
        }
        Ok(())
    }
}

/// The rows of the runs where every one of some columns has a value.
struct Table {
    /// One vector per column, the runs' kept rows concatenated.
    cols: Vec<Vec<f64>>,
    /// Kept rows per run.
    runs: Vec<usize>,
    /// Rows left out per run.
    left_out: Vec<usize>,
}

impl Table {
    fn new(files: &[RunFile], names: &[&str]) -> Table {
        let mut cols = vec![Vec::new(); names.len()];
        let mut runs = Vec::with_capacity(files.len());
        let mut left_out = Vec::with_capacity(files.len());
        for f in files {
            let src: Vec<&[Option<f64>]> =
                names.iter().map(|n| f.column(n).unwrap_or(&[])).collect();
            let (mut kept, mut out) = (0usize, 0usize);
            for row in 0..f.len() {
                let vals: Option<Vec<f64>> =
                    src.iter().map(|c| c.get(row).copied().flatten()).collect();
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

    fn rows(&self) -> usize {
        self.runs.iter().sum()
    }

    /// Reports left-out rows on stderr; fails when too few rows remain.
    fn report(&self, files: &[RunFile], what: &str, min_rows: usize) -> Result<()> {
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

/// The input columns of a selection on runs with `columns` (`source` names
/// the first run): `--inputs`, or every `T<number>` but the targets.
pub fn inputs_for(a: &SelectArgs, columns: &[String], source: &str) -> Result<Vec<String>> {
    let mut inputs: Vec<String> = a.inputs.iter().map(|s| s.trim().to_string()).collect();
    if inputs.is_empty() {
        inputs = columns
            .iter()
            .filter(|c| crate::data::runfile::is_temperature_column(c) && !a.target.contains(c))
            .cloned()
            .collect();
        if inputs.len() < 2 {
            bail!(
                "{source}: {} columns named T<number>: name at least two inputs with --inputs",
                inputs.len()
            );
        }
    }
    if inputs.len() < 2 {
        bail!("--inputs: name at least two columns to choose among");
    }
    for (i, name) in inputs.iter().enumerate() {
        if name.is_empty() {
            bail!("--inputs: empty column name");
        }
        if inputs[..i].contains(name) {
            bail!("--inputs: \"{name}\" is listed twice");
        }
        if a.target.contains(name) {
            bail!("\"{name}\" is both a --target and an input");
        }
    }
    Ok(inputs)
}

/// Reads the runs (only the columns the selection uses).
fn read(a: &SelectArgs) -> Result<Vec<RunFile>> {
    let first = a
        .data
        .first()
        .ok_or_else(|| anyhow!("--data: give at least one run file"))?;
    let header_only = ReadOptions {
        skip_bad_rows: true,
        only: Some(Vec::new()),
    };
    let inputs = if a.inputs.is_empty() {
        let head = RunFile::read(first, &header_only)?;
        inputs_for(a, &head.columns, &first.display().to_string())?
    } else {
        inputs_for(a, &[], "")?
    };
    let mut needed = inputs;
    needed.extend(a.target.iter().cloned());
    let opts = ReadOptions {
        skip_bad_rows: a.skip_bad_rows,
        only: Some(needed),
    };
    crate::data::source::read_runs(&a.data, &opts)
}

/// Every run has the columns `needed`, scalable.
fn check_runs(files: &[RunFile], needed: &[String]) -> Result<()> {
    for run in files {
        for n in needed {
            if !run.has_column(n) {
                bail!(
                    "{}: no column \"{n}\" (columns: {})",
                    run.path.display(),
                    run.columns.join(", ")
                );
            }
        }
        crate::data::dataset::check_scalable_columns(run)?;
    }
    Ok(())
}

/// Runs `thermcomp select`.
pub fn run(a: &SelectArgs) -> Result<()> {
    let out = select_files(a)?;
    if a.json {
        crate::data::fsio::print_line(&out.json.to_string())?;
    } else {
        crate::data::fsio::print(&out.text)?;
    }
    Ok(())
}

/// Checks the arguments, reads the runs and runs the method: everything
/// `thermcomp select` does but print. `thermcomp demo` calls it too.
pub fn select_files(a: &SelectArgs) -> Result<Output> {
    a.check()?;
    let files = read(a)?;
    select(a, &files)
}

/// The selection over runs in memory (`a.data` is not read): checks the
/// arguments, settles the inputs from the first run's columns, runs the
/// method.
pub fn select(a: &SelectArgs, files: &[RunFile]) -> Result<Output> {
    a.check()?;
    let first = files
        .first()
        .ok_or_else(|| anyhow!("--data: give at least one run file"))?;
    let inputs = inputs_for(a, &first.columns, &first.path.display().to_string())?;
    let needed: Vec<String> = inputs.iter().chain(&a.target).cloned().collect();
    check_runs(files, &needed)?;
    let names: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let mut out = match a.method {
        Method::Grey => run_grey(a, files, &names),
        Method::Wgrey => run_wgrey(a, files, &names),
        Method::Maxtree => run_maxtree(a, files, &names),
    }?;
    if let Value::Object(o) = &mut out.json {
        o.insert(
            "skipped_rows".into(),
            json!(crate::data::source::skipped_rows(files)),
        );
    }
    out.selected = out.json["selected"]
        .as_array()
        .map(|v| {
            v.iter()
                .filter_map(|s| s.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    Ok(out)
}

/// A method's result: the sensors picked, and the figures in both forms.
#[derive(Debug, Clone, Serialize)]
pub struct Output {
    /// The sensors picked, in the method's order.
    #[serde(skip)]
    pub selected: Vec<String>,
    /// `select --json`'s object (its `"selected"` lists the sensors picked;
    /// the rest are the method's own tables).
    #[serde(flatten)]
    pub json: Value,
    /// The tables `select` prints without `--json`.
    #[serde(skip)]
    pub text: String,
}

/// The columns `names` plus `target`, on the rows where all have values.
fn with_target<'a>(names: &[&'a str], target: &'a str) -> Vec<&'a str> {
    let mut v = names.to_vec();
    v.push(target);
    v
}

/// Applies the dimensionless processing, naming the column on failure.
fn scaled(col: &[f64], runs: &[usize], scale: grey::Scale, name: &str) -> Result<Vec<f64>> {
    grey::dimensionless(col, runs, scale).map_err(|e| {
        anyhow!(
            "{name}: {e} (--scale {}); choose another --scale: mean, interval or none",
            scale.name()
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
struct ScaleChoice {
    requested: grey::Scale,
    used: grey::Scale,
    /// The series that start at 0, with the first such run (1-based).
    zero_start: Vec<(String, usize)>,
    /// Every series of the computation (all use `used`).
    series: Vec<String>,
}

impl ScaleChoice {
    fn new(requested: grey::Scale, series: &[(&str, &[f64])], runs: &[usize]) -> Self {
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

    fn fell_back(&self) -> bool {
        !self.zero_start.is_empty()
    }

    /// `null`, or which series started at 0 and which took the fallback.
    fn json(&self) -> Value {
        if !self.fell_back() {
            return Value::Null;
        }
        json!({
            "from": self.requested.name(),
            "to": self.used.name(),
            "zero_start": self.zero_start.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(),
            "series": self.series,
        })
    }

    /// Says on stderr that `what` fell back, and why.
    fn note(&self, what: &str) {
        if let Some(line) = self.text(what) {
            eprintln!("note: {line}");
        }
    }

    /// One line on the fallback, if there was one.
    fn text(&self, what: &str) -> Option<String> {
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
fn series<'a>(names: &[&'a str], cols: &'a [Vec<f64>]) -> Vec<(&'a str, &'a [f64])> {
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
fn scaled_target(col: &[f64], runs: &[usize], scale: grey::Scale, name: &str) -> Result<Vec<f64>> {
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
fn target_correlations(t: &Table, names: &[&str], target: &str) -> Result<Vec<f64>> {
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

fn names_of(idx: &[usize], names: &[&str]) -> Vec<String> {
    idx.iter().map(|&i| names[i].to_string()).collect()
}

fn fmt_f(v: f64, prec: usize) -> String {
    if v.is_nan() {
        "-".into()
    } else if v.is_infinite() {
        "inf".into()
    } else {
        format!("{v:.prec$}")
    }
}

/// p-values print in scientific notation when small.
fn fmt_p(p: f64) -> String {
    if p.is_finite() && p > 0.0 && p < 1e-3 {
        format!("{p:.1e}")
    } else {
        fmt_f(p, 4)
    }
}

fn matrix_text(title: &str, m: &[Vec<f64>], names: &[&str]) -> String {
    let mut s = format!("{title}\n{:>6}", "");
    for n in names {
        s.push_str(&format!(" {n:>6}"));
    }
    s.push('\n');
    for (n, row) in names.iter().zip(m) {
        s.push_str(&format!("{n:>6}"));
        for v in row {
            s.push_str(&format!(" {v:>6.3}"));
        }
        s.push('\n');
    }
    s
}

fn regression_json(r: &stats::Regression) -> Map<String, Value> {
    let mut o = Map::new();
    o.insert("r".into(), json!(r.multiple_r()));
    o.insert("r2".into(), json!(r.r2));
    o.insert("adj_r2".into(), json!(r.adj_r2));
    o.insert("f".into(), json!(r.f));
    o.insert("df".into(), json!([r.p, r.n.saturating_sub(r.p + 1)]));
    o.insert("p_value".into(), json!(r.p_value));
    o.insert("rank_deficient".into(), json!(r.rank_deficient));
    o
}

fn run_grey(a: &SelectArgs, files: &[RunFile], names: &[&str]) -> Result<Output> {
    let target = a.target[0].as_str();
    // Degrees between the inputs: rows where every input has a value.
    let x = Table::new(files, names);
    x.report(files, "a value of every input", 2)?;
    let abs = grey::absolute_matrix(&x.cols, &x.runs);
    let rel_choice = ScaleChoice::new(grey::Scale::Initial, &series(names, &x.cols), &x.runs);
    rel_choice.note("the grey relative degree between the inputs");
    let rel = grey::relative_matrix(&x.cols, &x.runs, rel_choice.used).map_err(|(j, e)| {
        anyhow!(
            "{}: {e}: the grey relative degree needs its {} image",
            names[j],
            rel_choice.used.name()
        )
    })?;
    let rho = grey::comprehensive_matrix(&abs, &rel, a.theta);
    let groups = grey::clusters(&rho, a.level);
    let k = groups.len();
    if k > MAX_TYPICAL {
        bail!(
            "{k} groups at --level {}: more than {MAX_TYPICAL} typical variables would make {} combinations; lower --level so that fewer, larger groups form",
            a.level,
            (1u64 << k.min(63)) - 1
        );
    }

    // Correlation with the target: rows where the target and every input have values.
    let xy = Table::new(files, &with_target(names, target));
    xy.report(files, &format!("a value of {target} or of an input"), 3)?;
    let choice = ScaleChoice::new(
        a.scale.into(),
        &series(&with_target(names, target), &xy.cols),
        &xy.runs,
    );
    let with_what = format!("the grey correlation with {target}");
    choice.note(&with_what);
    let scale = choice.used;
    let ys = scaled_target(&xy.cols[names.len()], &xy.runs, scale, target)?;
    let xs = names
        .iter()
        .zip(&xy.cols)
        .map(|(n, c)| scaled(c, &xy.runs, scale, n))
        .collect::<Result<Vec<_>>>()?;
    let deng = grey::deng_coefficients(&ys, &xs, a.xi);
    let pearson = target_correlations(&xy, names, target)?;
    let mut typical = grey::typical(&groups, &deng);
    typical.sort_unstable();
    let y = &xy.cols[names.len()];
    let reg_cols: Vec<Vec<f64>> = typical.iter().map(|&j| xy.cols[j].clone()).collect();
    let basis = stats::Basis::new(&reg_cols, y).with_context(|| format!("regressing {target}"))?;
    let combos: Vec<(Vec<usize>, stats::Regression)> = grey::combinations(k)
        .into_iter()
        .map(|c| {
            let r = basis.fit(&c);
            (c.iter().map(|&i| typical[i]).collect(), r)
        })
        .collect();
    let best = combos
        .iter()
        .enumerate()
        .filter(|(_, (_, r))| !r.rank_deficient && r.adj_r2.is_finite())
        .fold(None::<(usize, f64)>, |acc, (i, (_, r))| match acc {
            Some((_, b)) if b >= r.adj_r2 => acc,
            _ => Some((i, r.adj_r2)),
        })
        .map(|(i, _)| i)
        .ok_or_else(|| {
            anyhow!(
                "{} rows are too few to compare the combinations of {k} typical variables",
                xy.rows()
            )
        })?;
    let selected = names_of(&combos[best].0, names);

    let group_of = |j: usize| groups.iter().position(|g| g.contains(&j)).unwrap_or(0);
    let variables: Vec<Value> = (0..names.len())
        .map(|j| {
            json!({"name": names[j], "grey_coefficient": deng[j], "pearson": pearson[j],
                   "group": group_of(j), "typical": typical.contains(&j)})
        })
        .collect();
    let combos_json: Vec<Value> = combos
        .iter()
        .map(|(c, r)| {
            let mut o = regression_json(r);
            o.insert("variables".into(), json!(names_of(c, names)));
            Value::Object(o)
        })
        .collect();
    let groups_named: Vec<Vec<String>> = groups.iter().map(|g| names_of(g, names)).collect();
    let json = json!({
        "method": "grey",
        "target": [target],
        "inputs": names,
        "selected": selected,
        "criterion": "adj_r2",
        "rows": {"inputs": x.rows(), "with_target": xy.rows(),
                 "left_out": xy.left_out.iter().sum::<usize>()},
        "scale": choice.requested.name(),
        "scale_used": scale.name(),
        "scale_fallback": choice.json(),
        "relative_images": rel_choice.used.name(),
        "relative_fallback": rel_choice.json(),
        "xi": a.xi,
        "theta": a.theta,
        "level": a.level,
        "absolute": abs,
        "relative": rel,
        "comprehensive": rho,
        "groups": groups_named,
        "typical": names_of(&typical, names),
        "variables": variables,
        "combinations": combos_json,
    });

    let notes = [
        rel_choice.text("the grey relative degree between the inputs"),
        choice.text(&with_what),
    ];
    let found = GreyFound {
        target,
        names,
        rows: xy.rows(),
        notes: notes.into_iter().flatten().collect(),
        scale,
        rho: &rho,
        deng: &deng,
        pearson: &pearson,
        groups: &groups,
        typical: &typical,
        combos: &combos,
        best,
        selected: &selected,
    };
    let text = grey_text(a, &found);
    Ok(Output {
        selected: Vec::new(),
        json,
        text,
    })
}

/// What `select --method grey` found, for its text tables.
struct GreyFound<'a> {
    target: &'a str,
    names: &'a [&'a str],
    /// Rows with the target and every input.
    rows: usize,
    /// Scale fallbacks to tell.
    notes: Vec<String>,
    scale: grey::Scale,
    /// Comprehensive correlation degrees between the inputs.
    rho: &'a [Vec<f64>],
    /// Deng's grey coefficient of each input with the target.
    deng: &'a [f64],
    pearson: &'a [f64],
    groups: &'a [Vec<usize>],
    typical: &'a [usize],
    combos: &'a [(Vec<usize>, stats::Regression)],
    /// Index of the best combination.
    best: usize,
    selected: &'a [String],
}

/// `select --method grey`'s text: the degrees, the groups, every
/// combination's regression and the pick.
fn grey_text(a: &SelectArgs, g: &GreyFound) -> String {
    let (target, names) = (g.target, g.names);
    let group_of = |j: usize| g.groups.iter().position(|c| c.contains(&j)).unwrap_or(0);
    let groups_named: Vec<Vec<String>> = g.groups.iter().map(|c| names_of(c, names)).collect();
    let mut text = format!(
        "grey selection for {target} ({} rows; seed 000: grey clustering at level {}, theta {}, Deng xi {}, --scale {})\n\n",
        g.rows,
        a.level,
        a.theta,
        a.xi,
        g.scale.name()
    );
    for line in &g.notes {
        text.push_str(&format!("{line}\n\n"));
    }
    text.push_str(&matrix_text(
        "grey comprehensive correlation degree between inputs",
        g.rho,
        names,
    ));
    text.push_str(&format!(
        "\n{:<8} {:>10} {:>9} {:>6}\n",
        "input", "grey_coef", "pearson", "group"
    ));
    for (j, name) in names.iter().enumerate() {
        text.push_str(&format!(
            "{:<8} {:>10.5} {:>9.5} {:>6}{}\n",
            name,
            g.deng[j],
            g.pearson[j],
            group_of(j) + 1,
            if g.typical.contains(&j) {
                "  typical"
            } else {
                ""
            }
        ));
    }
    text.push_str(&format!(
        "\ngroups: {}\n\n{:<40} {:>8} {:>8} {:>8} {:>11} {:>9}\n",
        groups_named
            .iter()
            .map(|g| format!("{{{}}}", g.join(", ")))
            .collect::<Vec<_>>()
            .join(" "),
        "combination",
        "R",
        "R2",
        "adj_R2",
        "F",
        "p"
    ));
    for (i, (c, r)) in g.combos.iter().enumerate() {
        text.push_str(&format!(
            "{:<40} {:>8.5} {:>8.5} {:>8.5} {:>11} {:>9}{}\n",
            names_of(c, names).join(","),
            r.multiple_r(),
            r.r2,
            r.adj_r2,
            fmt_f(r.f, 1),
            fmt_p(r.p_value),
            if i == g.best {
                "  <- best adjusted R2"
            } else {
                ""
            }
        ));
    }
    text.push_str(&format!("\nselected: {}\n", g.selected.join(", ")));
    text
}

fn run_wgrey(a: &SelectArgs, files: &[RunFile], names: &[&str]) -> Result<Output> {
    let requested: grey::Scale = a.scale.into();
    let w = wgrey::Weights {
        xi: a.xi,
        lambda1: a.lambda1,
        lambda2: a.lambda2,
    };
    if a.top > names.len() {
        eprintln!(
            "note: --top {} is more than the {} inputs: every input is kept",
            a.top,
            names.len()
        );
    }
    let mut per_target = Map::new();
    let mut tops = Vec::new();
    let mut gamma_cols = Vec::new();
    let mut fallbacks: Vec<String> = Vec::new();
    for t in &a.target {
        let xy = Table::new(files, &with_target(names, t));
        xy.report(files, &format!("a value of {t} or of an input"), 2)?;
        let choice = ScaleChoice::new(
            requested,
            &series(&with_target(names, t), &xy.cols),
            &xy.runs,
        );
        let with_what = format!("the grey correlativity with {t}");
        choice.note(&with_what);
        fallbacks.extend(choice.text(&with_what));
        let scale = choice.used;
        let ys = scaled_target(&xy.cols[names.len()], &xy.runs, scale, t)?;
        let xs = names
            .iter()
            .zip(&xy.cols)
            .map(|(n, c)| scaled(c, &xy.runs, scale, n))
            .collect::<Result<Vec<_>>>()?;
        let g = wgrey::gammas(&ys, &xs, &xy.runs, &w).map_err(|e| anyhow!("{t}: {e}"))?;
        let ranking = wgrey::top_k(&g, names.len());
        let top = wgrey::top_k(&g, a.top);
        per_target.insert(
            t.clone(),
            json!({"rows": xy.rows(), "left_out": xy.left_out.iter().sum::<usize>(),
                   "scale_used": scale.name(), "scale_fallback": choice.json(),
                   "gamma": g, "ranking": names_of(&ranking, names),
                   "top": names_of(&top, names)}),
        );
        tops.push(top);
        gamma_cols.push(g);
    }
    let selected = names_of(&wgrey::intersection(&tops), names);
    if selected.is_empty() {
        eprintln!(
            "note: no input is in the top {} of every target; raise --top or select per target",
            a.top
        );
    }
    let json = json!({
        "method": "wgrey",
        "target": a.target,
        "inputs": names,
        "selected": selected,
        "scale": requested.name(),
        "xi": a.xi,
        "lambda1": a.lambda1,
        "lambda2": a.lambda2,
        "top": a.top,
        "per_target": per_target,
    });
    let mut text = format!(
        "weighted grey correlativity (seed 002 Eq. 1; --scale {}, xi {}, lambda1 {}, lambda2 {})\n\n{}{:<8}",
        requested.name(),
        a.xi,
        a.lambda1,
        a.lambda2,
        fallbacks
            .iter()
            .map(|l| format!("{l}\n\n"))
            .collect::<String>(),
        "input"
    );
    for t in &a.target {
        text.push_str(&format!(" {t:>10}"));
    }
    text.push('\n');
    for (j, n) in names.iter().enumerate() {
        text.push_str(&format!("{n:<8}"));
        for g in &gamma_cols {
            text.push_str(&format!(" {:>10.5}", g[j]));
        }
        text.push('\n');
    }
    text.push('\n');
    for (t, top) in a.target.iter().zip(&tops) {
        text.push_str(&format!(
            "top {} of {t}: {}\n",
            a.top,
            names_of(top, names).join(", ")
        ));
    }
    let shown = if selected.is_empty() {
        "none".to_string()
    } else {
        selected.join(", ")
    };
    text.push_str(&format!("selected: {shown}\n"));
    Ok(Output {
        selected: Vec::new(),
        json,
        text,
    })
}

fn run_maxtree(a: &SelectArgs, files: &[RunFile], names: &[&str]) -> Result<Output> {
    let target = a.target[0].as_str();
    let x = Table::new(files, names);
    x.report(files, "a value of every input", 3)?;
    let r = stats::pearson_matrix(&x.cols).map_err(|j| {
        anyhow!(
            "{} is constant over the {} rows used: its correlation is undefined; leave it out with --inputs",
            names[j],
            x.rows()
        )
    })?;
    let sim: Vec<Vec<f64>> = r
        .iter()
        .map(|row| row.iter().map(|v| v.abs()).collect())
        .collect();
    let edges = maxtree::prim(&sim);
    let levels = maxtree::levels(names.len(), &edges);

    let xy = Table::new(files, &with_target(names, target));
    xy.report(files, &format!("a value of {target} or of an input"), 3)?;
    let target_r = target_correlations(&xy, names, target)?;
    let y = &xy.cols[names.len()];
    let basis = stats::Basis::new(&xy.cols[..names.len()], y)
        .with_context(|| format!("regressing {target}"))?;
    let fits: Vec<LevelFit> = levels
        .iter()
        .map(|l| {
            let reps = maxtree::representatives(&l.groups, &target_r);
            let reg = basis.fit(&reps);
            let col = basis.collinearity(&reps);
            LevelFit { reps, reg, col }
        })
        .collect();
    let scores: Vec<maxtree::LevelScore> = fits
        .iter()
        .map(|f| maxtree::LevelScore {
            r2: f.reg.r2,
            p_value: f.reg.p_value,
            min_tolerance: if f.reg.rank_deficient {
                0.0
            } else {
                f.col.min_tolerance()
            },
        })
        .collect();
    let choice = maxtree::choose(&scores, a.alpha, a.min_gain, a.min_tolerance)
        .ok_or_else(|| anyhow!("the maximal tree has no edges"))?;
    if choice.fallback {
        eprintln!(
            "note: no level's regression is significant at --alpha {} with every tolerance >= {}: took the smallest p-value",
            a.alpha, a.min_tolerance
        );
    }
    let chosen = &fits[choice.index];
    let selected = names_of(&chosen.reps, names);
    let rule = if choice.fallback {
        "fallback: smallest p-value (no level passed)".to_string()
    } else {
        format!(
            "smallest level with p < {} , every tolerance >= {} and R2 >= best such R2 - {}",
            a.alpha, a.min_tolerance, a.min_gain
        )
    };

    let levels_json: Vec<Value> = levels
        .iter()
        .zip(&fits)
        .map(|(l, f)| {
            let mut o = regression_json(&f.reg);
            o.insert("lambda".into(), json!(l.lambda));
            let groups: Vec<Vec<String>> = l.groups.iter().map(|g| names_of(g, names)).collect();
            o.insert("groups".into(), json!(groups));
            o.insert("representatives".into(), json!(names_of(&f.reps, names)));
            o.insert("condition_number".into(), json!(f.col.condition_number));
            o.insert("vif".into(), json!(f.col.vif));
            o.insert("significant".into(), json!(f.reg.p_value < a.alpha));
            // Keep the contract's keys first for readers that print it.
            let mut ordered = Map::new();
            for k in ["lambda", "groups"] {
                if let Some(v) = o.remove(k) {
                    ordered.insert(k.into(), v);
                }
            }
            ordered.extend(o);
            Value::Object(ordered)
        })
        .collect();
    let tree_json: Vec<Value> = edges
        .iter()
        .map(|e| json!({"a": names[e.a], "b": names[e.b], "weight": e.weight}))
        .collect();
    let json = json!({
        "method": "maxtree",
        "target": [target],
        "inputs": names,
        "selected": selected,
        "rows": {"inputs": x.rows(), "with_target": xy.rows(),
                 "left_out": xy.left_out.iter().sum::<usize>()},
        "pearson": r,
        "similarity": sim,
        "tree": tree_json,
        "target_correlation": target_r,
        "levels": levels_json,
        "chosen_level": choice.index,
        "alpha": a.alpha,
        "min_gain": a.min_gain,
        "min_tolerance": a.min_tolerance,
        "rule": rule,
    });

    let found = MaxtreeFound {
        target,
        names,
        rows: xy.rows(),
        edges: &edges,
        target_r: &target_r,
        levels: &levels,
        fits: &fits,
        chosen: choice.index,
        rule: &rule,
        selected: &selected,
    };
    let text = maxtree_text(&found);
    Ok(Output {
        selected: Vec::new(),
        json,
        text,
    })
}

/// One level's representatives, regression and collinearity.
struct LevelFit {
    reps: Vec<usize>,
    reg: stats::Regression,
    col: stats::Collinearity,
}

/// What `select --method maxtree` found, for its text tables.
struct MaxtreeFound<'a> {
    target: &'a str,
    names: &'a [&'a str],
    /// Rows with the target and every input.
    rows: usize,
    edges: &'a [maxtree::Edge],
    /// Pearson r of each input with the target.
    target_r: &'a [f64],
    levels: &'a [maxtree::Level],
    fits: &'a [LevelFit],
    /// Index of the chosen level.
    chosen: usize,
    rule: &'a str,
    selected: &'a [String],
}

/// `select --method maxtree`'s text: the tree, each level's fit, the
/// groups and the pick.
fn maxtree_text(g: &MaxtreeFound) -> String {
    let (target, names) = (g.target, g.names);
    let mut text = format!(
        "maximal-tree selection for {target} ({} rows; seed 003: similarity |Pearson r|, Prim from {})\n\ntree edges (added in this order):\n",
        g.rows,
        names[0]
    );
    for e in g.edges {
        text.push_str(&format!(
            "  {}-{} {:.5}\n",
            names[e.a], names[e.b], e.weight
        ));
    }
    text.push_str(&format!("\n{:<8} {:>8}\n", "input", "r_target"));
    for (n, v) in names.iter().zip(g.target_r) {
        text.push_str(&format!("{n:<8} {v:>8.5}\n"));
    }
    text.push_str(&format!(
        "\n{:>3} {:>8} {:<34} {:>8} {:>8} {:>11} {:>9} {:>9} {:>10}\n",
        "#", "lambda", "representatives", "R2", "adj_R2", "F", "p", "cond", "max_VIF"
    ));
    for (i, (l, f)) in g.levels.iter().zip(g.fits).enumerate() {
        let max_vif = f.col.vif.iter().copied().fold(1.0, f64::max);
        text.push_str(&format!(
            "{:>3} {:>8.5} {:<34} {:>8.5} {:>8.5} {:>11} {:>9} {:>9} {:>10}{}\n",
            i + 1,
            l.lambda,
            names_of(&f.reps, names).join(","),
            f.reg.r2,
            f.reg.adj_r2,
            fmt_f(f.reg.f, 1),
            fmt_p(f.reg.p_value),
            fmt_f(f.col.condition_number, 1),
            fmt_f(max_vif, 1),
            if i == g.chosen { "  <- chosen" } else { "" }
        ));
    }
    text.push_str("\ngroups per level:\n");
    for (i, l) in g.levels.iter().enumerate() {
        let g: Vec<String> = l
            .groups
            .iter()
            .map(|g| format!("{{{}}}", names_of(g, names).join(",")))
            .collect();
        text.push_str(&format!("{:>3} {:.5} {}\n", i + 1, l.lambda, g.join(" ")));
    }
    text.push_str(&format!(
        "\nrule: {}\nselected: {}\n",
        g.rule,
        g.selected.join(", ")
    ));
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temperature_names() {
        assert!(
            crate::data::runfile::is_temperature_column("T1")
                && crate::data::runfile::is_temperature_column("T16")
        );
        assert!(
            !crate::data::runfile::is_temperature_column("T")
                && !crate::data::runfile::is_temperature_column("Tx")
                && !crate::data::runfile::is_temperature_column("t1")
        );
        assert!(!crate::data::runfile::is_temperature_column("T1_c"));
    }

    #[test]
    fn table_keeps_complete_rows_per_run() {
        let csv = "t_s,T1,T2,y\n0,1,2,3\n1,,2,3\n2,1,2,\n3,4,5,6\n";
        let f = RunFile::from_reader("a.csv", csv.as_bytes(), &ReadOptions::default()).unwrap();
        let t = Table::new(std::slice::from_ref(&f), &["T1", "T2"]);
        assert_eq!((t.runs.clone(), t.left_out.clone()), (vec![3], vec![1]));
        let t = Table::new(&[f.clone(), f], &["T1", "T2", "y"]);
        assert_eq!(t.runs, vec![2, 2]);
        assert_eq!(t.cols[0], vec![1.0, 4.0, 1.0, 4.0]);
    }
}
