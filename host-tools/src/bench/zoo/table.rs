//! A run in memory: named columns of equal length, written as a run file
//! (CONTRACT.md section 2).

use anyhow::{bail, Result};
use std::fmt::Write as _;
use std::path::Path;

/// One column.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Header name.
    pub name: String,
    /// One value per row.
    pub values: Vec<f64>,
    /// Decimals written.
    pub decimals: usize,
}

/// A run: columns in file order, `t_s` first.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunTable {
    /// The columns.
    pub columns: Vec<Column>,
}

impl RunTable {
    /// Appends a column.
    pub fn push(&mut self, name: &str, values: Vec<f64>, decimals: usize) {
        self.columns.push(Column {
            name: name.to_string(),
            values,
            decimals,
        });
    }

    /// The values of column `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .find(|c| c.name == name)
            .map(|c| &c.values[..])
    }

    /// Column names in order.
    pub fn names(&self) -> Vec<&str> {
        self.columns.iter().map(|c| c.name.as_str()).collect()
    }

    /// Drops the named columns (a machine that does not log them).
    pub fn drop_columns(&mut self, names: &[String]) {
        self.columns.retain(|c| !names.contains(&c.name));
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, |c| c.values.len())
    }

    /// The run as CSV text.
    pub fn to_csv(&self) -> Result<String> {
        let n = self.rows();
        if self.columns.iter().any(|c| c.values.len() != n) {
            bail!("run table: columns of unequal length");
        }
        let mut s = self.names().join(",");
        s.push('\n');
        for k in 0..n {
            for (j, c) in self.columns.iter().enumerate() {
                if j > 0 {
                    s.push(',');
                }
                let _ = write!(s, "{:.*}", c.decimals, c.values[k]);
            }
            s.push('\n');
        }
        Ok(s)
    }

    /// Writes the run to `path` (atomically).
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::data::fsio::write_bytes_atomic(path, self.to_csv()?.as_bytes())
    }
}
