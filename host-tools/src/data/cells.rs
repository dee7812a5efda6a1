//! A column of cells as held in memory: one `f64` per sample, `NaN` for a
//! missing (empty) cell.
//!
//! Why `NaN` rather than `Option<f64>`: half the memory (8 bytes a cell, not
//! 16), which at a million rows of 17 columns is 136 MB less to allocate,
//! fault in and walk. `NaN` is free to mean "missing" because no cell can
//! hold it as a value: the run-file reader refuses every non-finite number
//! with a `file:line:column` error, and [`crate::data::runfile::RunFile::from_columns`]
//! takes `NaN` as a missing cell, as an empty CSV cell is. [`Cells`] gives
//! the values back as `Option<f64>`, so code reading a column never compares
//! with `NaN` itself.

use std::fmt;

/// How a cell is stored: its value, or `NaN` when it is missing.
pub fn stored(value: Option<f64>) -> f64 {
    value.unwrap_or(f64::NAN)
}

/// How a stored cell reads: `None` for `NaN` (missing), else its value.
pub fn read(stored: f64) -> Option<f64> {
    (!stored.is_nan()).then_some(stored)
}

/// What a series of values does: no value at all, one value throughout,
/// or moves. A target that never moves has nothing to fit, test or rank
/// against (every score of it is 0/0), so `fit`, `refit` and `select`
/// refuse it by this.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Level {
    /// No value seen.
    #[default]
    Empty,
    /// Every value seen is this one.
    Flat(f64),
    /// Two values seen differ.
    Moves,
}

impl Level {
    /// The level once `v` is seen too.
    #[must_use]
    pub fn push(self, v: f64) -> Self {
        match self {
            Self::Empty => Self::Flat(v),
            Self::Flat(w) if w == v => self,
            _ => Self::Moves,
        }
    }

    /// The level of `values`.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Self {
        values.into_iter().fold(Self::Empty, Self::push)
    }
}

/// A borrowed column of stored cells (see the module docs): each cell reads
/// as `Option<f64>`, `None` where it is missing.
#[derive(Clone, Copy, Default)]
pub struct Cells<'a> {
    stored: &'a [f64],
}

impl<'a> Cells<'a> {
    /// The column held in `stored` (`NaN`: a missing cell).
    pub fn new(stored: &'a [f64]) -> Self {
        Cells { stored }
    }

    /// Number of cells (missing ones included).
    pub fn len(self) -> usize {
        self.stored.len()
    }

    /// Whether the column has no cells.
    pub fn is_empty(self) -> bool {
        self.stored.is_empty()
    }

    /// Cell `row`: `None` when it is missing or past the end.
    pub fn get(self, row: usize) -> Option<f64> {
        self.stored.get(row).copied().and_then(read)
    }

    /// Every cell in order, `None` for a missing one.
    pub fn iter(self) -> impl DoubleEndedIterator<Item = Option<f64>> + Clone + 'a {
        self.stored.iter().map(|&v| read(v))
    }

    /// The values of the cells that are not missing, in order.
    pub fn present(self) -> impl Iterator<Item = f64> + Clone + 'a {
        self.stored.iter().copied().filter(|v| !v.is_nan())
    }

    /// The stored form, `NaN` for a missing cell: for arithmetic that
    /// carries a missing cell through as `NaN` (one test at the end).
    pub fn stored(self) -> &'a [f64] {
        self.stored
    }

    /// The cells `range` of this column.
    pub fn slice(self, range: std::ops::Range<usize>) -> Cells<'a> {
        Cells::new(self.stored.get(range).unwrap_or_default())
    }

    /// The cells copied out as options (for code that keeps its own column).
    pub fn to_options(self) -> Vec<Option<f64>> {
        self.iter().collect()
    }
}

/// A column logged when it changes, read row by row: a missing cell takes
/// the last value present before it (`None` before the first). The tool
/// length is such a column (a CNC logs it at a tool change; the hub holds
/// the last one received the same way).
#[derive(Clone, Copy, Debug, Default)]
pub struct LastLogged {
    last: Option<f64>,
    held: usize,
}

impl LastLogged {
    /// The value for a row whose cell is `cell`.
    pub fn next(&mut self, cell: Option<f64>) -> Option<f64> {
        match cell {
            Some(v) => self.last = Some(v),
            None => self.held += usize::from(self.last.is_some()),
        }
        self.last
    }

    /// Rows so far whose cell was missing and that took a held value.
    pub fn held(&self) -> usize {
        self.held
    }
}

/// A column read cell by cell, `None` for a missing cell: [`Cells`], or
/// cells already held as options (a resampled column).
pub trait CellColumn {
    /// Cell `row`: `None` when it is missing or past the end.
    fn cell(&self, row: usize) -> Option<f64>;
}

impl CellColumn for Cells<'_> {
    fn cell(&self, row: usize) -> Option<f64> {
        self.get(row)
    }
}

impl CellColumn for [Option<f64>] {
    fn cell(&self, row: usize) -> Option<f64> {
        self.get(row).copied().flatten()
    }
}

impl CellColumn for Vec<Option<f64>> {
    fn cell(&self, row: usize) -> Option<f64> {
        self.as_slice().cell(row)
    }
}

impl<'a> IntoIterator for Cells<'a> {
    type Item = Option<f64>;
    type IntoIter = std::iter::Map<std::slice::Iter<'a, f64>, fn(&f64) -> Option<f64>>;

    /// [`Cells::iter`].
    fn into_iter(self) -> Self::IntoIter {
        self.stored.iter().map(|&v| read(v))
    }
}

/// Equal when the same cells are missing and the others are equal (so two
/// missing cells are equal, unlike two `NaN`s).
impl PartialEq for Cells<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

impl fmt::Debug for Cells<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_level_is_empty_flat_or_moving() {
        assert_eq!(Level::of([]), Level::Empty);
        assert_eq!(Level::of([2.5, 2.5, 2.5]), Level::Flat(2.5));
        assert_eq!(Level::of([2.5, 2.5, 2.6, 2.5]), Level::Moves);
        assert_eq!(Level::Moves.push(1.0), Level::Moves);
    }

    #[test]
    fn a_missing_cell_reads_as_none_and_others_as_stored() {
        let stored_cells = [stored(Some(1.5)), stored(None), stored(Some(-0.0))];
        let c = Cells::new(&stored_cells);
        assert_eq!(c.len(), 3);
        assert_eq!(c.get(0), Some(1.5));
        assert_eq!(c.get(1), None);
        // -0.0 is a value, kept to the bit.
        assert_eq!(c.get(2).map(f64::to_bits), Some((-0.0f64).to_bits()));
        assert_eq!(c.get(3), None, "past the end");
        assert_eq!(c.to_options(), [Some(1.5), None, Some(-0.0)]);
        assert_eq!(c.present().collect::<Vec<_>>(), [1.5, -0.0]);
        assert!(c.stored()[1].is_nan());
    }

    #[test]
    fn columns_compare_by_cells_with_missing_equal_to_missing() {
        let a = [1.0, f64::NAN];
        let b = [1.0, f64::NAN];
        let c = [1.0, 2.0];
        assert_eq!(Cells::new(&a), Cells::new(&b));
        assert_ne!(Cells::new(&a), Cells::new(&c));
        assert_ne!(Cells::new(&a), Cells::new(&a[..1]));
        assert_eq!(format!("{:?}", Cells::new(&a)), "[Some(1.0), None]");
    }

    #[test]
    fn a_slice_is_the_cells_in_range_and_empty_out_of_range() {
        let a = [1.0, f64::NAN, 3.0];
        assert_eq!(Cells::new(&a).slice(1..3).to_options(), [None, Some(3.0)]);
        assert!(Cells::new(&a).slice(2..9).is_empty());
    }
}
