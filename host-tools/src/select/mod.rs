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
//! The job ([`SelectParams`] -> [`ValidSelectParams`] -> [`select`] over
//! runs in memory -> [`SelectOutcome`]) lines up the rows ([`rows`]), calls
//! the pure functions of the method modules step by step ([`methods`]) and
//! returns typed figures ([`outcome`]); the CLI (`cli::select`) prints them
//! as tables or, with `--json`, as one JSON object. Rows where a needed
//! value is missing are left out of that computation and counted on stderr. With `--scale initial`, a grey
//! computation in which a series starts at 0 uses interval processing for
//! all its series, and says so ([`INITIAL_FALLBACK`]). docs/select.md has
//! the formulas and their sources.

pub mod grey;
mod job;
pub mod maxtree;
mod methods;
pub mod outcome;
mod rows;
pub mod wgrey;

pub use job::{select, SelectParams, ValidSelectParams};
pub use outcome::SelectOutcome;
pub use rows::INITIAL_FALLBACK;

use crate::data::runfile::{ReadOptions, RunFile};
use anyhow::{anyhow, Result};
use clap::{Args, ValueEnum};
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
    /// The name on the command line.
    pub fn name(self) -> &'static str {
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
        skip_bad_rows: true,
        only: Some(Vec::new()),
    };
    let inputs = if a.inputs.is_empty() {
        let head = RunFile::read(first, &header_only)?;
        p.params()
            .inputs_for(&head.columns, &first.display().to_string())?
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

#[cfg(test)]
mod tests {
    use super::rows::Table;
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
