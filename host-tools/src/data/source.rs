//! Reading the runs a model is applied to: bad rows noted on stderr and
//! counted, and the CAN interface name checked (the flag groups that name
//! them are the CLI's, `crate::cli::source`).

use crate::data::runfile::{ReadOptions, RowError, RunFile};
use anyhow::Result;
use std::path::PathBuf;

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
