//! Columns kept off the heap: equal-length `f64` columns written once to an
//! unnamed temporary file (deleted when dropped) and read back whole or a
//! block of rows at a time.
//!
//! The diagnosis compares every channel both runs share (21 on an
//! FL_THERMAL-shaped pair), but works on one or two of them at a time; held
//! in memory, their simulated values and residuals alone were 336 bytes a
//! row (336 MB at 10^6 rows, docs/benchmarks.md "Scale"). Spilled, a
//! channel costs its bytes only while it is worked on, and reading it back
//! from the page cache is a copy, so the values are the same bits.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::ops::Range;
use std::sync::{Mutex, OnceLock};

/// Bytes of one value in the file (an `f64`, little-endian).
const VALUE_BYTES: usize = std::mem::size_of::<f64>();

/// Columns of `rows` values each in an unnamed temporary file.
#[derive(Debug)]
pub struct Spill {
    file: Mutex<File>,
    rows: usize,
    cols: usize,
    /// The first failed read back, reported by [`Spill::check`].
    failed: OnceLock<String>,
}

impl Spill {
    /// An empty store for columns of `rows` values.
    pub fn new(rows: usize) -> std::io::Result<Self> {
        Ok(Spill {
            file: Mutex::new(tempfile::tempfile()?),
            rows,
            cols: 0,
            failed: OnceLock::new(),
        })
    }

    /// Values per column.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Appends column `values` (`rows` of them); returns its index.
    pub fn push(&mut self, values: &[f64]) -> std::io::Result<usize> {
        assert_eq!(values.len(), self.rows, "a spilled column's length");
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let at = self.offset(self.cols, 0);
        let file = self.file.get_mut().unwrap_or_else(|e| e.into_inner());
        file.seek(SeekFrom::Start(at))?;
        file.write_all(&bytes)?;
        self.cols += 1;
        Ok(self.cols - 1)
    }

    /// Column `col` whole.
    pub fn column(&self, col: usize) -> Vec<f64> {
        self.rows_of(col, 0..self.rows)
    }

    /// Rows `rows` of column `col`. A read of the file this store wrote
    /// fails only on an I/O fault of the machine: then the values are NaN
    /// and the fault is kept for [`Spill::check`], which every result built
    /// from these columns passes before it is returned (no panic, no NaN
    /// reported as a figure).
    pub fn rows_of(&self, col: usize, rows: Range<usize>) -> Vec<f64> {
        let (col_ok, rows_ok) = (col < self.cols, rows.end <= self.rows);
        let mut bytes = vec![0u8; rows.len() * VALUE_BYTES];
        let read = if col_ok && rows_ok {
            let mut file = self.file.lock().unwrap_or_else(|e| e.into_inner());
            file.seek(SeekFrom::Start(self.offset(col, rows.start)))
                .and_then(|_| file.read_exact(&mut bytes))
        } else {
            Err(std::io::Error::other(format!(
                "column {col} rows {rows:?} outside the {} x {} stored",
                self.cols, self.rows
            )))
        };
        if let Err(e) = read {
            let _ = self.failed.set(e.to_string());
            return vec![f64::NAN; rows.len()];
        }
        bytes
            .chunks_exact(VALUE_BYTES)
            .map(|b| f64::from_le_bytes(b.try_into().unwrap_or([0; VALUE_BYTES])))
            .collect()
    }

    /// Whether every read back succeeded; else the first fault.
    pub fn check(&self) -> std::io::Result<()> {
        match self.failed.get() {
            None => Ok(()),
            Some(e) => Err(std::io::Error::other(format!(
                "reading back the diagnosis's temporary file: {e}"
            ))),
        }
    }

    /// Byte offset of row `row` of column `col`.
    fn offset(&self, col: usize, row: usize) -> u64 {
        ((col * self.rows + row) * VALUE_BYTES) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_come_back_bit_for_bit_whole_and_by_rows() {
        let a: Vec<f64> = (0..1000).map(|k| (k as f64 * 0.37).sin() / 3.0).collect();
        let b: Vec<f64> = vec![f64::MIN_POSITIVE, -0.0, 1e300, f64::NAN, 22.1234];
        let mut s = Spill::new(1000).unwrap();
        let mut t = Spill::new(5).unwrap();
        assert_eq!((s.push(&a).unwrap(), t.push(&b).unwrap()), (0, 0));
        let a2: Vec<f64> = a.iter().map(|v| -v).collect();
        assert_eq!(s.push(&a2).unwrap(), 1);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&s.column(0)), bits(&a));
        assert_eq!(bits(&s.column(1)), bits(&a2));
        assert_eq!(bits(&s.rows_of(1, 990..1000)), bits(&a2[990..]));
        assert_eq!(bits(&t.column(0)), bits(&b));
        assert!(s.rows_of(0, 3..3).is_empty());
        assert!(s.check().is_ok());
        // A read outside what was stored: NaN, and the fault reported.
        assert!(s.rows_of(2, 0..2).iter().all(|v| v.is_nan()));
        let e = s.check().unwrap_err().to_string();
        assert!(e.contains("column 2 rows 0..2 outside the 2 x 1000"), "{e}");
    }
}
