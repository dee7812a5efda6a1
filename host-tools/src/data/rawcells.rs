//! A run file's cells as text, row for row, for commands that copy columns
//! they do not compute (`fivepoint` keeps a run's other columns as written,
//! text columns included), and text written as one CSV field.

use anyhow::{bail, Context, Result};
use std::path::Path;

/// `text` as one CSV field: quoted (its quotes doubled) where it holds a
/// comma, a quote or a line break, so a run's file name (or a model's
/// output name in the header) stays one field and whole (a comma in a run
/// name used to become `_`, a line break to split the row).
pub fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// A CSV's header and data rows as text.
pub struct RawTable {
    /// Header names, trimmed (a UTF-8 byte order mark removed).
    pub header: Vec<String>,
    /// Data rows, each field trimmed.
    pub rows: Vec<Vec<String>>,
}

/// The header and data rows of the CSV at `path`, each field trimmed
/// of surrounding whitespace, as the run-file reader sees rows: empty lines
/// are skipped by both. `expect_rows` is the row count the run-file reader
/// kept; a different count is an error rather than a silent misalignment.
pub fn read(path: &Path, expect_rows: usize) -> Result<RawTable> {
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(std::io::BufReader::new(file));
    let header = rdr
        .headers()
        .with_context(|| format!("{}", path.display()))?
        .iter()
        .map(|f| f.trim_start_matches('\u{feff}').trim().to_owned())
        .collect();
    let mut rows = Vec::with_capacity(expect_rows);
    for record in rdr.records() {
        let record = record.with_context(|| format!("{}", path.display()))?;
        rows.push(record.iter().map(|f| f.trim().to_owned()).collect());
    }
    if rows.len() != expect_rows {
        bail!(
            "{}: {} data rows as text but {} as numbers: cannot copy its columns row for row",
            path.display(),
            rows.len(),
            expect_rows
        );
    }
    Ok(RawTable { header, rows })
}
