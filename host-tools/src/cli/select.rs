//! `thermcomp select`: the flags, reading the run files, the typed job
//! ([`crate::select::select`]) and its outcome printed as one JSON object
//! with `--json` or as the method's text tables.

use crate::data::fsio;
use crate::data::runfile::{ReadOptions, RowStream, RunFile};
use crate::select::outcome::{GreyOutcome, MaxtreeOutcome, WgreyOutcome};
use crate::select::{grey, select, Method, SelectOutcome, SelectParams, ValidSelectParams};
use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

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
    /// The job's parameters: every flag but the files and the output form.
    pub fn params(&self) -> SelectParams {
        SelectParams {
            target: self.target.clone(),
            inputs: self.inputs.clone(),
            method: self.method,
            scale: self.scale.into(),
            xi: self.xi,
            theta: self.theta,
            level: self.level,
            lambda1: self.lambda1,
            lambda2: self.lambda2,
            top: self.top,
            alpha: self.alpha,
            min_gain: self.min_gain,
            min_tolerance: self.min_tolerance,
        }
    }
}

/// Reads the runs (only the columns the selection uses).
fn read(a: &SelectArgs, p: &ValidSelectParams) -> Result<Vec<RunFile>> {
    let first = a
        .data
        .first()
        .ok_or_else(|| anyhow!("--data: give at least one run file"))?;
    let header_only = ReadOptions {
        skip_bad_rows: false,
        only: Some(Vec::new()),
    };
    let inputs = if a.inputs.is_empty() {
        // The header alone (the rows are read once, below).
        let head = RowStream::open(first, &header_only)?;
        p.params()
            .inputs_for(head.columns(), &first.display().to_string())?
    } else {
        p.params().inputs_for(&[], "")?
    };
    let mut needed = inputs;
    needed.extend(a.target.iter().cloned());
    let opts = ReadOptions {
        skip_bad_rows: a.skip_bad_rows,
        only: Some(needed),
    };
    crate::data::source::read_runs(&a.data, &opts)
}

/// Checks the arguments, reads the runs and runs the method: everything
/// `thermcomp select` does but print.
pub fn select_files(a: &SelectArgs) -> Result<SelectOutcome> {
    let p = a.params().check()?;
    let files = read(a, &p)?;
    select(&p, &files)
}

/// Runs `thermcomp select`.
pub fn run(a: &SelectArgs) -> Result<()> {
    let out = select_files(a)?;
    if a.json {
        fsio::print_line(&serde_json::to_value(&out)?.to_string())
    } else {
        fsio::print(&text(&out))
    }
}

/// The tables `select` prints without `--json`.
pub fn text(out: &SelectOutcome) -> String {
    match out {
        SelectOutcome::Grey(g) => grey_text(g),
        SelectOutcome::Wgrey(w) => wgrey_text(w),
        SelectOutcome::Maxtree(m) => maxtree_text(m),
    }
}

/// A figure with `prec` decimals; `-` for NaN, `inf` for infinity.
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

/// A square matrix under `title`, rows and columns named `names`.
fn matrix_text(title: &str, m: &[Vec<f64>], names: &[String]) -> String {
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

/// Groups as `{a, b} {c}` (`sep` between the names).
fn groups_text(groups: &[Vec<String>], sep: &str, between: &str) -> String {
    groups
        .iter()
        .map(|g| format!("{{{}}}", g.join(sep)))
        .collect::<Vec<_>>()
        .join(between)
}

/// `select --method grey`'s text: the degrees, the groups, every
/// combination's regression and the pick.
fn grey_text(g: &GreyOutcome) -> String {
    let mut text = format!(
        "grey selection for {} ({} rows; seed 000: grey clustering at level {}, theta {}, Deng xi {}, --scale {})\n\n",
        g.target[0], g.rows.with_target, g.level, g.theta, g.xi, g.scale_used
    );
    for line in &g.notes {
        text.push_str(&format!("{line}\n\n"));
    }
    text.push_str(&matrix_text(
        "grey comprehensive correlation degree between inputs",
        &g.comprehensive,
        &g.inputs,
    ));
    text.push_str(&format!(
        "\n{:<8} {:>10} {:>9} {:>6}\n",
        "input", "grey_coef", "pearson", "group"
    ));
    for v in &g.variables {
        text.push_str(&format!(
            "{:<8} {:>10.5} {:>9.5} {:>6}{}\n",
            v.name,
            v.grey_coefficient,
            v.pearson,
            v.group + 1,
            if v.typical { "  typical" } else { "" }
        ));
    }
    text.push_str(&format!(
        "\ngroups: {}\n\n{:<40} {:>8} {:>8} {:>8} {:>11} {:>9}\n",
        groups_text(&g.groups, ", ", " "),
        "combination",
        "R",
        "R2",
        "adj_R2",
        "F",
        "p"
    ));
    for (i, c) in g.combinations.iter().enumerate() {
        let r = &c.regression;
        text.push_str(&format!(
            "{:<40} {:>8.5} {:>8.5} {:>8.5} {:>11} {:>9}{}\n",
            c.variables.join(","),
            r.r,
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

/// `select --method wgrey`'s text: each input's correlativity with each
/// target, the top sets and the pick.
fn wgrey_text(w: &WgreyOutcome) -> String {
    let mut text = format!(
        "weighted grey correlativity (seed 002 Eq. 1; --scale {}, xi {}, lambda1 {}, lambda2 {})\n\n{}{:<8}",
        w.scale,
        w.xi,
        w.lambda1,
        w.lambda2,
        w.notes
            .iter()
            .map(|l| format!("{l}\n\n"))
            .collect::<String>(),
        "input"
    );
    for t in &w.target {
        text.push_str(&format!(" {t:>10}"));
    }
    text.push('\n');
    for (j, n) in w.inputs.iter().enumerate() {
        text.push_str(&format!("{n:<8}"));
        for t in &w.target {
            text.push_str(&format!(" {:>10.5}", w.per_target[t].gamma[j]));
        }
        text.push('\n');
    }
    text.push('\n');
    for t in &w.target {
        text.push_str(&format!(
            "top {} of {t}: {}\n",
            w.top,
            w.per_target[t].top.join(", ")
        ));
    }
    let shown = if w.selected.is_empty() {
        "none".to_string()
    } else {
        w.selected.join(", ")
    };
    text.push_str(&format!("selected: {shown}\n"));
    text
}

/// `select --method maxtree`'s text: the tree, each level's fit, the
/// groups and the pick.
fn maxtree_text(m: &MaxtreeOutcome) -> String {
    let mut text = format!(
        "maximal-tree selection for {} ({} rows; seed 003: similarity |Pearson r|, Prim from {})\n\ntree edges (added in this order):\n",
        m.target[0], m.rows.with_target, m.inputs[0]
    );
    for e in &m.tree {
        text.push_str(&format!("  {}-{} {:.5}\n", e.a, e.b, e.weight));
    }
    text.push_str(&format!("\n{:<8} {:>8}\n", "input", "r_target"));
    for (n, v) in m.inputs.iter().zip(&m.target_correlation) {
        text.push_str(&format!("{n:<8} {v:>8.5}\n"));
    }
    text.push_str(&format!(
        "\n{:>3} {:>8} {:<34} {:>8} {:>8} {:>11} {:>9} {:>9} {:>10}\n",
        "#", "lambda", "representatives", "R2", "adj_R2", "F", "p", "cond", "max_VIF"
    ));
    for (i, l) in m.levels.iter().enumerate() {
        let max_vif = l.vif.iter().copied().fold(1.0, f64::max);
        text.push_str(&format!(
            "{:>3} {:>8.5} {:<34} {:>8.5} {:>8.5} {:>11} {:>9} {:>9} {:>10}{}\n",
            i + 1,
            l.lambda,
            l.representatives.join(","),
            l.regression.r2,
            l.regression.adj_r2,
            fmt_f(l.regression.f, 1),
            fmt_p(l.regression.p_value),
            fmt_f(l.condition_number, 1),
            fmt_f(max_vif, 1),
            if i == m.chosen_level {
                "  <- chosen"
            } else {
                ""
            }
        ));
    }
    text.push_str("\ngroups per level:\n");
    for (i, l) in m.levels.iter().enumerate() {
        text.push_str(&format!(
            "{:>3} {:.5} {}\n",
            i + 1,
            l.lambda,
            groups_text(&l.groups, ",", " ")
        ));
    }
    text.push_str(&format!(
        "\nrule: {}\nselected: {}\n",
        m.rule,
        m.selected.join(", ")
    ));
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_params_carry_the_cli_defaults() {
        for (method, name) in [
            (Method::Grey, "grey"),
            (Method::Wgrey, "wgrey"),
            (Method::Maxtree, "maxtree"),
        ] {
            let pairs = [
                ("data".to_string(), "run.csv".to_string()),
                ("target".to_string(), "dz_um".to_string()),
                ("method".to_string(), name.to_string()),
            ];
            let args: SelectArgs = crate::cli::pairs::args_from_pairs("select", &pairs).unwrap();
            assert_eq!(
                format!("{:?}", args.params()),
                format!("{:?}", SelectParams::new(vec!["dz_um".into()], method))
            );
        }
    }
}
