//! The arguments that name a model and the runs to apply it to, shared by
//! every subcommand that runs a model (`predict`, `eval`, and later `replay`).

use crate::data::fsio::{named, Named};
use crate::data::runfile::{ReadOptions, RowError, RunFile};
use crate::runner::ColumnMap;
use anyhow::Result;
use clap::Args;
use model_core::ValidModel;
use std::path::PathBuf;

/// `--model BLOB` or `--spec SPEC.toml`.
#[derive(Args)]
pub struct ModelSource {
    /// The model blob.
    #[arg(long, required_unless_present = "spec", conflicts_with = "spec")]
    pub model: Option<PathBuf>,
    /// Or a model spec (TOML), built in memory exactly as `model build` would.
    #[arg(long)]
    pub spec: Option<PathBuf>,
}

impl ModelSource {
    /// The validated model.
    pub fn load(&self) -> Result<ValidModel> {
        crate::data::blobfile::load(self.model.as_deref(), self.spec.as_deref())
    }

    /// The files read, with their flags, for [`crate::data::fsio::check_distinct`].
    pub fn paths(&self) -> Vec<Named<'_>> {
        let model = self.model.iter().map(|p| named("--model", p));
        model
            .chain(self.spec.iter().map(|p| named("--spec", p)))
            .collect()
    }
}

/// `--data` (repeatable), `--map`, `--skip-bad-rows`.
#[derive(Args)]
pub struct RunSource {
    /// A run file (CSV); give it several times for several runs (each
    /// restarts the model's state).
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// Read model name NAME from column COLUMN (repeatable): an input (T1=T5),
    /// or an output compared with a differently named column (dz_um=ch1_um).
    #[arg(long = "map", value_name = "NAME=COLUMN")]
    pub map: Vec<String>,
    /// Skip rows with unparsable cells instead of failing (they are counted and reported).
    #[arg(long)]
    pub skip_bad_rows: bool,
}

impl RunSource {
    /// The files read, with their flags, for [`crate::data::fsio::check_distinct`].
    pub fn paths(&self) -> Vec<Named<'_>> {
        self.data.iter().map(|p| named("--data", p)).collect()
    }

    /// The `--map` pairs.
    pub fn column_map(&self) -> Result<ColumnMap> {
        ColumnMap::parse(&self.map)
    }

    /// Reads every run, parsing only the columns in `needed` (others are kept
    /// by name and ignored), and reports skipped rows on stderr.
    pub fn read(&self, needed: Vec<String>) -> Result<Vec<RunFile>> {
        read_runs(&self.data, &self.read_options(needed))
    }

    /// The reader's options for these runs, reading only the `needed` columns.
    pub fn read_options(&self, needed: Vec<String>) -> ReadOptions {
        ReadOptions {
            skip_bad_rows: self.skip_bad_rows,
            only: Some(needed),
        }
    }
}

/// Reads run files with `opts`, telling stderr how many bad rows each
/// skipped (with `--skip-bad-rows`), so nothing is dropped silently.
pub fn read_runs(paths: &[PathBuf], opts: &ReadOptions) -> Result<Vec<RunFile>> {
    paths
        .iter()
        .map(|p| {
            let run = RunFile::read(p, opts)?;
            let first = run.skipped.first().map(|s| &s.reason);
            note_skipped(p, run.skipped.len(), first);
            Ok(run)
        })
        .collect()
}

/// The note on the rows of `path` skipped as bad (none if `first` is `None`).
pub fn note_skipped(path: &std::path::Path, skipped: usize, first: Option<&RowError>) {
    if let Some(first) = first {
        eprintln!(
            "note: {}: skipped {skipped} bad rows (--skip-bad-rows); first: {first}",
            path.display()
        );
    }
}

/// Rows left out of `runs` under `--skip-bad-rows`, for the `skipped_rows`
/// key of every `--json` object that read run files.
pub fn skipped_rows<'a>(runs: impl IntoIterator<Item = &'a RunFile>) -> usize {
    runs.into_iter().map(|r| r.skipped.len()).sum()
}

/// `replay --interface`: a CAN interface name as Linux allows one (1 to 15
/// bytes, IFNAMSIZ - 1) with no whitespace or control characters. It is
/// written into every candump log line, so a newline in it would inject a
/// line and a space would split a field.
pub fn interface_name(s: &str) -> std::result::Result<String, String> {
    if let Some(c) = s.chars().find(|c| c.is_control() || c.is_whitespace()) {
        return Err(format!(
            "it holds {c:?}: no whitespace or control characters in an interface name"
        ));
    }
    if s.is_empty() || s.len() > 15 {
        return Err(format!(
            "{} bytes; a CAN interface name has 1 to 15",
            s.len()
        ));
    }
    Ok(s.to_string())
}
