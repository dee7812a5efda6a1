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
//! returns typed figures ([`outcome`]); the CLI (`cli::select`: the flags,
//! reading the files) prints them as tables or, with `--json`, as one JSON
//! object. Rows where a needed
//! value is missing are left out of that computation and counted on stderr. With `--scale initial`, a grey
//! computation in which a series starts at 0 uses interval processing for
//! all its series, and says so ([`INITIAL_FALLBACK`]). docs/select.md has
//! the formulas and their sources.

pub mod grey;
mod job;
pub mod maxtree;
mod methods;
pub mod outcome;
mod params;
mod rows;
pub mod wgrey;

pub use job::select;
pub use outcome::SelectOutcome;
pub use params::{SelectParams, ValidSelectParams};
pub use rows::INITIAL_FALLBACK;

/// Largest number of typical variables `grey` combines: 2^12 - 1 = 4095
/// regressions. Past that the table is unreadable and the choice among
/// thousands of near-equal fits means nothing.
pub const MAX_TYPICAL: usize = 12;

/// Selection methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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

#[cfg(test)]
mod tests {
    use super::rows::Table;
    use crate::data::runfile::{ReadOptions, RunFile};

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
