//! The `select` job as a library call (linfa's shape, as `fit::job`):
//! [`SelectParams`] (params.rs) -> [`SelectParams::check`] ->
//! [`ValidSelectParams`] -> [`select`] over runs in memory ->
//! [`SelectOutcome`], which serialises to the object `select --json` prints.

use super::outcome::SelectOutcome;
use super::params::ValidSelectParams;
use super::{methods, Method};
use crate::data::cells::Level;
use crate::data::runfile::RunFile;
use anyhow::{anyhow, bail, Result};

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
    }
    Ok(())
}

/// Refuses a target with one value over every run: there is nothing to
/// rank the inputs by (grey and maxtree divided by zero on it, wgrey gave
/// every input the same grade).
fn refuse_flat_targets(files: &[RunFile], targets: &[String]) -> Result<()> {
    for t in targets {
        let values = files
            .iter()
            .filter_map(|r| r.column(t))
            .flat_map(|c| c.present());
        match Level::of(values) {
            Level::Empty => bail!("{t} has no values in any run"),
            Level::Flat(v) => {
                bail!("{t} is constant ({v}) in every run: nothing to rank the inputs by")
            }
            Level::Moves => {}
        }
    }
    Ok(())
}

/// The selection over runs in memory: settles the inputs from the first
/// run's columns, checks the runs have them, runs the method.
pub fn select(p: &ValidSelectParams, files: &[RunFile]) -> Result<SelectOutcome> {
    let a = p.params();
    let first = files
        .first()
        .ok_or_else(|| anyhow!("--data: give at least one run file"))?;
    let inputs = a.inputs_for(&first.columns, &first.path.display().to_string())?;
    let needed: Vec<String> = inputs.iter().chain(&a.target).cloned().collect();
    check_runs(files, &needed)?;
    refuse_flat_targets(files, &a.target)?;
    let names: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let skipped_rows = crate::data::source::skipped_rows(files);
    Ok(match a.method {
        Method::Grey => SelectOutcome::Grey(methods::grey(a, files, &names, skipped_rows)?),
        Method::Wgrey => SelectOutcome::Wgrey(methods::wgrey(a, files, &names, skipped_rows)?),
        Method::Maxtree => {
            SelectOutcome::Maxtree(methods::maxtree(a, files, &names, skipped_rows)?)
        }
    })
}
