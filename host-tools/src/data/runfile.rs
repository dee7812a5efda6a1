//! Reader for measured run files: the CSV recordings of a machine-tool run
//! (time, spindle speed, temperatures, measured thermal drift, ...) that every
//! `thermcomp` command starts from.
//!
//! The format is the product's contract: one header row, one row per sample,
//! a mandatory, strictly increasing `t_s` column and any number of other
//! numeric columns, which are all kept (so a model can use a sensor this code
//! has never heard of). An empty cell is a missing value. Anything else that is
//! not a finite number is an error pointing at `file:line:column`, because a
//! silently dropped or invented value would end up inside a compensation model
//! running on a real machine. Callers that prefer to carry on over damaged
//! rows can ask for them to be skipped; skipped rows are recorded, never lost.
//!
//! [`RowStream`] is the same reader row by row, in memory bounded by a row
//! whatever the file's length ([`RunFile::read`] is it collected into
//! columns); [`SamplingTally`] gives a streamed run's [`Sampling`].
//!
//! Besides the reader, this module holds the two helpers every consumer of a
//! run file needs to put runs on a common time base: [`uniform_grid`] and
//! [`resample_linear`].

use crate::data::cells::{self, Cells};
use crate::num::shown::Num;
use std::borrow::Cow;
use std::collections::{HashMap, VecDeque};
use std::fmt;
use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};

/// Name of the mandatory time column, in seconds.
///
/// It is kept out of [`RunFile::columns`] because, unlike the data columns, it
/// can never have missing values: every sample must say when it was taken.
pub const TIME_COLUMN: &str = "t_s";

/// Whether a column is a temperature sensor by the contract's naming
/// (`T1`, `T2`, ...): the default candidates of `select` and `fit`.
pub fn is_temperature_column(name: &str) -> bool {
    numbered(name, 'T')
}

/// Whether `name` is `prefix` followed by one or more digits (`T12`, `S3`).
fn numbered(name: &str, prefix: char) -> bool {
    name.strip_prefix(prefix)
        .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Largest grid [`uniform_grid`] will build.
///
/// 10 million points is far beyond any real run on a model's grid (115 days
/// at 1 s; the runner keeps a few `Option<f64>` vectors of this length per
/// channel), so hitting it means a wrong unit or a swapped argument, which is
/// better reported than answered by exhausting memory.
pub const MAX_GRID_POINTS: usize = 10_000_000;

/// Cell text longer than this many characters is shortened in error messages,
/// so that a run of garbage (say, a binary file read by mistake) still gives a
/// one-line message.
const MAX_SHOWN_CELL_CHARS: usize = 40;

/// Longest line read, bytes: a run file's rows are a few hundred bytes, and
/// even 10 000 columns of 20-character cells fit. A longer "line" is a binary
/// file or a device (`/dev/zero`) that would otherwise be read without end.
pub const MAX_LINE_BYTES: u64 = 1 << 20;
/// Most columns in a header (far above any machine's sensor count).
pub const MAX_COLUMNS: usize = 10_000;
/// Most data rows in one file: 100 days at 10 Hz; memory stays bounded.
pub const MAX_ROWS: usize = 100_000_000;
/// Most cells (rows x columns) in one file: 1.6 GB of values at most.
pub const MAX_CELLS: usize = 100_000_000;

/// UTF-8 byte order mark, written by some spreadsheet programs.
const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// How strictly [`RunFile::read`] treats damaged data rows.
///
/// The default is strict, because a model fitted on partly unread data is
/// worse than no model; skipping is an explicit choice of the user.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// Skip data rows with an error (bad or non-finite number, a value its
    /// column's [`Quantity`] cannot take, wrong field count, missing or
    /// non-increasing time) instead of failing, recording
    /// each one in [`RunFile::skipped`]. Header errors are always fatal, since
    /// without a valid header no row can be understood.
    pub skip_bad_rows: bool,
    /// Read only these columns (and `t_s`). The others are listed in
    /// [`RunFile::columns`] but their cells are not parsed: CONTRACT.md keeps
    /// unknown columns and ignores them, so a text column (an operator's
    /// note, a program name) must not make a run unreadable. `None` reads all.
    pub only: Option<Vec<String>>,
}

/// A data row left out because of [`ReadOptions::skip_bad_rows`], kept so the
/// user can be told exactly what was dropped and why.
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedRow {
    /// 1-based line in the file where the row starts (the header is line 1).
    pub line: u64,
    /// Good rows read before it: it stood between rows `before - 1` and
    /// `before` of [`RunFile::t_s`] (so row-for-row outputs can keep its place).
    pub before: usize,
    /// What was wrong with it; displays as the same message the strict reader
    /// would have failed with.
    pub reason: RowError,
}

impl fmt::Display for SkippedRow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.reason.fmt(f)
    }
}

/// Summary of the time steps of a run, so callers can check the sampling they
/// assume (most model fitting wants a uniform step) instead of trusting it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sampling {
    /// Number of samples.
    pub n: usize,
    /// Median time step in seconds; `None` with fewer than two samples, where
    /// there is no step to speak of. The median, not the mean, so that a few
    /// gaps do not distort the nominal step.
    pub dt_median_s: Option<f64>,
    /// Smallest time step in seconds; `None` with fewer than two samples.
    pub dt_min_s: Option<f64>,
    /// Largest time step in seconds (the longest gap); `None` with fewer than
    /// two samples.
    pub dt_max_s: Option<f64>,
    /// Whether every step is within `1e-6 * |median| + 1e-9` s of the median,
    /// i.e. equal up to the rounding of the printed times. `false` with fewer
    /// than two samples, because no step can be relied on.
    pub is_uniform: bool,
}

impl Sampling {
    /// Relative tolerance of [`Sampling::is_uniform`].
    pub const REL_TOL: f64 = 1e-6;
    /// Absolute tolerance of [`Sampling::is_uniform`], in seconds.
    pub const ABS_TOL_S: f64 = 1e-9;
    /// Most grid points per row a resampling builds ([`Sampling::check_grid`]):
    /// a model step a hundredth of the logger's. Beyond it the grid is
    /// mostly interpolation: a gap of days in one file, or a step in the
    /// wrong unit.
    pub const MAX_POINTS_PER_ROW: usize = 100;
    /// A grid this small is built whatever the rows (a short run on a
    /// fine model step costs nothing).
    pub const SMALL_GRID_POINTS: usize = 100_000;

    /// Refuses to resample this run onto a grid of `points` points every
    /// `dt` s when that is more than [`Sampling::MAX_POINTS_PER_ROW`] per
    /// row (and more than [`Sampling::SMALL_GRID_POINTS`]): the grid would be
    /// mostly made up, and a gap of years between two rows (one line's
    /// time typed wrong, two runs in one file) would build millions of
    /// points and hours of work from a small file.
    pub fn check_grid(&self, points: usize, dt: f64) -> Result<(), GridError> {
        let allowed = self
            .n
            .saturating_mul(Self::MAX_POINTS_PER_ROW)
            .max(Self::SMALL_GRID_POINTS);
        if points <= allowed {
            return Ok(());
        }
        Err(GridError::MostlyInterpolated {
            rows: self.n,
            points,
            dt,
            gap: self.dt_max_s,
            median: self.dt_median_s,
        })
    }

    /// Summarise the steps of the sample times `t`.
    ///
    /// Public so that a time base built or filtered elsewhere can be checked
    /// the same way as a file's. `t` is expected to be finite and increasing,
    /// as in a [`RunFile`]; other input gives a meaningless but panic-free
    /// answer (never uniform if a step is not finite).
    pub fn of(t: &[f64]) -> Sampling {
        let mut steps: Vec<f64> = t.iter().zip(t.iter().skip(1)).map(|(a, b)| b - a).collect();
        steps.sort_unstable_by(f64::total_cmp);
        let mid = steps.len() / 2;
        let median = if steps.len() % 2 == 1 {
            steps.get(mid).copied()
        } else {
            match (
                mid.checked_sub(1).and_then(|i| steps.get(i)),
                steps.get(mid),
            ) {
                (Some(a), Some(b)) => Some(a + (b - a) / 2.0),
                _ => None,
            }
        };
        let is_uniform = median.is_some_and(|m| {
            let tol = Self::REL_TOL * m.abs() + Self::ABS_TOL_S;
            steps.iter().all(|d| (d - m).abs() <= tol)
        });
        Sampling {
            n: t.len(),
            dt_median_s: median,
            dt_min_s: steps.iter().copied().reduce(f64::min),
            dt_max_s: steps.iter().copied().reduce(f64::max),
            is_uniform,
        }
    }
}

/// [`Sampling`] of a run seen one time at a time (a [`RowStream`]), equal
/// to [`Sampling::of`] on all the times: the steps are kept as counts per
/// distinct value, so memory grows with the number of distinct steps (a
/// few for a logger's fixed period), not with the run's length.
#[derive(Debug, Clone, Default)]
pub struct SamplingTally {
    n: usize,
    first: Option<f64>,
    last: Option<f64>,
    /// Steps by their bits (positive finite f64s sort as their bits do).
    steps: std::collections::BTreeMap<u64, usize>,
}

impl SamplingTally {
    /// Adds the next time (after the previous one, as in a run).
    pub fn push(&mut self, t: f64) {
        if let Some(last) = self.last {
            *self.steps.entry((t - last).to_bits()).or_insert(0) += 1;
        }
        self.first.get_or_insert(t);
        self.last = Some(t);
        self.n += 1;
    }

    /// The first and last times, if any.
    pub fn span(&self) -> Option<(f64, f64)> {
        self.first.zip(self.last)
    }

    /// The `k`-th smallest step (0-based).
    fn kth(&self, k: usize) -> Option<f64> {
        let mut seen = 0;
        for (&bits, &count) in &self.steps {
            seen += count;
            if k < seen {
                return Some(f64::from_bits(bits));
            }
        }
        None
    }

    /// The summary [`Sampling::of`] gives for the times pushed.
    pub fn sampling(&self) -> Sampling {
        let len = self.n.saturating_sub(1);
        let mid = len / 2;
        let median = if len % 2 == 1 {
            self.kth(mid)
        } else {
            match (mid.checked_sub(1).and_then(|i| self.kth(i)), self.kth(mid)) {
                (Some(a), Some(b)) => Some(a + (b - a) / 2.0),
                _ => None,
            }
        };
        let min = self.steps.keys().next().map(|&b| f64::from_bits(b));
        let max = self.steps.keys().next_back().map(|&b| f64::from_bits(b));
        // |d - m| <= tol holds on an interval of d: the extremes decide.
        let is_uniform = median.is_some_and(|m| {
            let tol = Sampling::REL_TOL * m.abs() + Sampling::ABS_TOL_S;
            [min, max].iter().flatten().all(|d| (d - m).abs() <= tol)
        });
        Sampling {
            n: self.n,
            dt_median_s: median,
            dt_min_s: min,
            dt_max_s: max,
            is_uniform,
        }
    }
}

/// A run file read into memory, column by column.
///
/// Column-major because every consumer works on whole signals (fit a model to
/// `T1..T16`, resample `dx_um`), never on rows.
#[derive(Debug, Clone)]
pub struct RunFile {
    /// The path it was read from, as given (for [`RunFile::from_reader`], the
    /// name given), so later messages can name the file the way the user did.
    pub path: PathBuf,
    /// Header names other than `t_s`, trimmed, in file order.
    pub columns: Vec<String>,
    /// Sample times in seconds: finite and strictly increasing.
    pub t_s: Vec<f64>,
    /// Values of `columns[i]` in `values[i]`, one per sample, stored as
    /// [`cells`] (`NaN` for an empty cell). Private so the columns cannot get
    /// out of step with the names.
    values: Vec<Vec<f64>>,
    /// Rows left out under [`ReadOptions::skip_bad_rows`], in file order.
    pub skipped: Vec<SkippedRow>,
    /// `read[i]`: whether `columns[i]` was parsed (see [`ReadOptions::only`]).
    read: Vec<bool>,
}

impl RunFile {
    /// Read the run file at `path`.
    ///
    /// Errors name the file by `path` as given, which is how the user typed it.
    pub fn read(path: &Path, opts: &ReadOptions) -> Result<RunFile, RunFileError> {
        let file = path.display().to_string();
        match File::open(path) {
            Ok(reader) => {
                let size = reader.metadata().ok().map(|m| m.len());
                Self::parse(file, path.to_path_buf(), reader, opts, size)
            }
            Err(source) => Err(RunFileError::Io { file, source }),
        }
    }

    /// Read a run file from any byte source; `name` stands for the file in
    /// errors and in [`RunFile::path`]. Lets tests and callers with data in
    /// memory (stdin, an archive) use exactly the reader that files use.
    pub fn from_reader<R: io::Read>(
        name: &str,
        r: R,
        opts: &ReadOptions,
    ) -> Result<RunFile, RunFileError> {
        Self::parse(name.to_owned(), PathBuf::from(name), r, opts, None)
    }

    /// A run held in memory as columns (a pandas DataFrame, a numpy array):
    /// `t_s` and `(name, values)` per column, `NaN` for a missing cell (what
    /// an empty CSV cell means). `None` values: a column that is kept by name
    /// but not numeric (ignored unless a model names it, as in a file).
    ///
    /// The same rules as [`RunFile::read`], with `name` for the file and the
    /// place a CSV would have (line = row + 2, column 1 = `t_s`) in errors:
    /// `t_s` present, finite and strictly increasing; no duplicate or empty
    /// names; cells finite and at most [`MAX_CELL_MAGNITUDE`] in magnitude,
    /// and within the range of the [`Quantity`] a column's name states.
    pub fn from_columns(
        name: &str,
        t_s: Vec<f64>,
        columns: Vec<(String, Option<Vec<f64>>)>,
    ) -> Result<RunFile, RunFileError> {
        let file = name.to_owned();
        check_names(&file, &columns)?;
        let row_error = |row: usize, kind| {
            RunFileError::Row(RowError {
                file: file.clone(),
                line: row as u64 + 2,
                kind,
            })
        };
        if let Some(row) = t_s.iter().position(|t| !t.is_finite()) {
            return Err(row_error(row, RowErrorKind::MissingTime { column: 1 }));
        }
        for (row, pair) in t_s.windows(2).enumerate() {
            if pair[1] <= pair[0] {
                let kind = RowErrorKind::TimeNotIncreasing {
                    column: 1,
                    time: pair[1],
                    previous: pair[0],
                };
                return Err(row_error(row + 1, kind));
            }
        }
        let mut values = Vec::with_capacity(columns.len());
        let mut read = Vec::with_capacity(columns.len());
        let mut names = Vec::with_capacity(columns.len());
        for (index, (col, cells)) in columns.into_iter().enumerate() {
            let cells = cells.unwrap_or_default();
            if !cells.is_empty() && cells.len() != t_s.len() {
                return Err(RunFileError::Csv {
                    file,
                    message: format!(
                        "column {col} has {} rows, t_s has {}",
                        cells.len(),
                        t_s.len()
                    ),
                });
            }
            read.push(!cells.is_empty() || t_s.is_empty());
            for (row, &v) in cells.iter().enumerate() {
                check_memory_cell(v, index + 2, &col).map_err(|k| row_error(row, k))?;
            }
            // `NaN` is a missing cell here and in storage alike.
            values.push(if cells.is_empty() {
                vec![f64::NAN; t_s.len()]
            } else {
                cells
            });
            names.push(col);
        }
        if t_s.is_empty() {
            return Err(RunFileError::NoDataRows {
                file,
                skipped: 0,
                first_skipped: None,
            });
        }
        Ok(RunFile {
            path: PathBuf::from(name),
            columns: names,
            t_s,
            values,
            skipped: Vec::new(),
            read,
        })
    }

    /// Number of samples (data rows kept).
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Whether there are no samples. A successfully read file always has at
    /// least one, so this is only `true` for a value emptied by its owner.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// The values of the column called `name`, one per sample (`None` for an
    /// empty cell), or `None` if there is no such column. `t_s` is not a
    /// column here: it is [`RunFile::t_s`], which cannot have gaps.
    pub fn column(&self, name: &str) -> Option<Cells<'_>> {
        let index = self.columns.iter().position(|c| c == name)?;
        if !self.read.get(index).copied().unwrap_or(false) {
            return None;
        }
        self.values.get(index).map(|v| Cells::new(v))
    }

    /// Whether the file has a column called `name` (not counting `t_s`, which
    /// every run file has), so callers can check the signals a model needs
    /// before starting work.
    pub fn has_column(&self, name: &str) -> bool {
        self.columns.iter().any(|c| c == name)
    }

    /// Every column with its values, in file order, for a caller that
    /// handles columns it does not know by name (the in-memory round trip
    /// of `host-tools/tests/memory_runs.rs`).
    pub fn iter_columns(&self) -> impl Iterator<Item = (&str, Cells<'_>)> {
        self.columns
            .iter()
            .zip(&self.values)
            .zip(&self.read)
            .filter(|(_, read)| **read)
            .map(|((name, values), _)| (name.as_str(), Cells::new(values)))
    }

    /// The time steps of the run; see [`Sampling`].
    pub fn sampling(&self) -> Sampling {
        Sampling::of(&self.t_s)
    }

    /// The whole-run reader: a [`RowStream`] collected into columns.
    fn parse<R: io::Read>(
        file: String,
        path: PathBuf,
        reader: R,
        opts: &ReadOptions,
        size_hint: Option<u64>,
    ) -> Result<RunFile, RunFileError> {
        let mut stream = RowStream::start(file, reader, opts)?;
        let mut t_s = Vec::new();
        let mut values = vec![Vec::new(); stream.columns().len()];
        let mut skipped = Vec::new();
        while let Some(item) = stream.next_item()? {
            match item {
                StreamItem::Row(t) => {
                    t_s.push(t);
                    stream.push_row_into(&mut values);
                    if t_s.len() == SIZE_SAMPLE_ROWS {
                        reserve_for(
                            size_hint,
                            stream.offset(),
                            &mut t_s,
                            &mut values,
                            &stream.read,
                        );
                    }
                }
                StreamItem::Skipped(s) => skipped.push(s),
            }
        }
        stream.finish(skipped.first().map(|s| &s.reason))?;
        let RowStream { header, read, .. } = stream;
        Ok(RunFile {
            path,
            columns: header.columns,
            t_s,
            values,
            skipped,
            read,
        })
    }
}

/// One data row of a [`RowStream`]: a kept row (its time; its cells are
/// [`RowStream::row`]) or a row skipped under [`ReadOptions::skip_bad_rows`].
#[derive(Debug, Clone, PartialEq)]
pub enum StreamItem {
    /// A good row at this time.
    Row(f64),
    /// A bad row left out; `before` counts the good rows read before it.
    Skipped(SkippedRow),
}

/// A run file read row by row in bounded memory: the same header rules,
/// row checks (strictly increasing `t_s`, field counts, numbers) and
/// `file:line:column` errors as [`RunFile::read`], which is this stream
/// collected into columns. Only the columns of [`ReadOptions::only`] are
/// parsed; memory is one row, whatever the file's length.
pub struct RowStream<R> {
    file: String,
    rdr: csv::Reader<LineStarts<R>>,
    record: csv::ByteRecord,
    header: Header,
    /// `read[i]`: whether data column `i` is parsed.
    read: Vec<bool>,
    max_rows: usize,
    skip_bad_rows: bool,
    /// The last kept row's cells, in column order (`None`: empty or unread).
    row: Vec<Option<f64>>,
    last_t: Option<f64>,
    kept: usize,
    skipped: usize,
}

impl RowStream<File> {
    /// Open the run file at `path` (errors name it as given).
    pub fn open(path: &Path, opts: &ReadOptions) -> Result<Self, RunFileError> {
        let file = path.display().to_string();
        match File::open(path) {
            Ok(reader) => Self::start(file, reader, opts),
            Err(source) => Err(RunFileError::Io { file, source }),
        }
    }
}

impl<R: io::Read> RowStream<R> {
    /// Read and check the header of `reader`; `file` names it in errors.
    pub fn start(file: String, reader: R, opts: &ReadOptions) -> Result<Self, RunFileError> {
        // No header handling, no field-count check and no trimming by csv:
        // all three are done here so that they give this module's messages
        // and so that a wrong field count is a skippable row error.
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(LineStarts::new(reader));
        let mut record = csv::ByteRecord::new();
        if !next_record(&mut rdr, &mut record, &file)? {
            return Err(RunFileError::EmptyFile { file });
        }
        let header = Header::parse(&record, line_of(&mut rdr, &record), &file)?;
        if header.columns.len() > MAX_COLUMNS {
            return Err(RunFileError::TooLarge {
                file,
                line: 1,
                what: format!("more than {MAX_COLUMNS} columns"),
            });
        }
        let max_rows = MAX_ROWS.min(MAX_CELLS / (header.columns.len() + 1));
        let read: Vec<bool> = header
            .columns
            .iter()
            .map(|c| opts.only.as_ref().is_none_or(|only| only.contains(c)))
            .collect();
        Ok(RowStream {
            file,
            rdr,
            record,
            row: Vec::with_capacity(header.columns.len()),
            header,
            read,
            max_rows,
            skip_bad_rows: opts.skip_bad_rows,
            last_t: None,
            kept: 0,
            skipped: 0,
        })
    }

    /// The next data row, `None` at the end of the file. A bad row is an
    /// error, or, with [`ReadOptions::skip_bad_rows`], a
    /// [`StreamItem::Skipped`].
    pub fn next_item(&mut self) -> Result<Option<StreamItem>, RunFileError> {
        if !next_record(&mut self.rdr, &mut self.record, &self.file)? {
            return Ok(None);
        }
        // Asked for every row, not only bad ones, so that `LineStarts`
        // can drop what is behind it.
        let line = line_of(&mut self.rdr, &self.record);
        self.check_row_limit(line)?;
        match self
            .header
            .parse_row(&self.record, self.last_t, &self.read, &mut self.row)
        {
            Ok(t) => {
                self.last_t = Some(t);
                self.kept += 1;
                Ok(Some(StreamItem::Row(t)))
            }
            Err(kind) => {
                let reason = RowError {
                    file: self.file.clone(),
                    line,
                    kind,
                };
                if !self.skip_bad_rows {
                    return Err(RunFileError::Row(reason));
                }
                self.skipped += 1;
                Ok(Some(StreamItem::Skipped(SkippedRow {
                    line,
                    before: self.kept,
                    reason,
                })))
            }
        }
    }

    fn check_row_limit(&self, line: u64) -> Result<(), RunFileError> {
        if self.kept + self.skipped < self.max_rows {
            return Ok(());
        }
        Err(RunFileError::TooLarge {
            file: self.file.clone(),
            line,
            what: format!(
                "more than {} data rows of {} columns",
                self.max_rows,
                self.header.columns.len() + 1
            ),
        })
    }

    /// Bytes read so far (header included).
    fn offset(&self) -> u64 {
        self.rdr.get_ref().offset
    }

    /// Appends the last row's read cells to their columns.
    fn push_row_into(&self, values: &mut [Vec<f64>]) {
        for ((column, value), _) in values
            .iter_mut()
            .zip(&self.row)
            .zip(&self.read)
            .filter(|(_, r)| **r)
        {
            column.push(cells::stored(*value));
        }
    }

    /// After the last item: the error [`RunFile::read`] gives for a file
    /// without a good data row (`first_skipped`: the first skipped row's
    /// error, if the caller kept it).
    pub fn finish(&self, first_skipped: Option<&RowError>) -> Result<(), RunFileError> {
        if self.kept > 0 {
            return Ok(());
        }
        Err(RunFileError::NoDataRows {
            file: self.file.clone(),
            skipped: self.skipped,
            first_skipped: first_skipped.map(|e| Box::new(e.clone())),
        })
    }
}

impl<R> RowStream<R> {
    /// The file name as given, for messages.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// Header names other than `t_s`, in file order.
    pub fn columns(&self) -> &[String] {
        &self.header.columns
    }

    /// Index of the parsed column `name` in [`RowStream::row`]; `None` if
    /// the file has no such column or it is not read.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        let i = self.header.columns.iter().position(|c| c == name)?;
        self.read.get(i).copied().unwrap_or(false).then_some(i)
    }

    /// The cells of the last [`StreamItem::Row`], in column order.
    pub fn row(&self) -> &[Option<f64>] {
        &self.row
    }

    /// Good rows so far.
    pub fn rows(&self) -> usize {
        self.kept
    }

    /// Rows skipped so far.
    pub fn skipped(&self) -> usize {
        self.skipped
    }
}

/// Rows read before the columns are sized for the whole file from its
/// length and the bytes those rows took (so a 1 M-row file is not grown by
/// doubling, which peaks at twice its size).
const SIZE_SAMPLE_ROWS: usize = 256;

/// Reserves room for the rows a file of `size` bytes holds if its rows are
/// as long as the first ones (`consumed` bytes so far, header included; 2 %
/// spare); only the columns that are read. A wrong guess only costs a
/// regrowth, never a row.
fn reserve_for(
    size: Option<u64>,
    consumed: u64,
    t_s: &mut Vec<f64>,
    values: &mut [Vec<f64>],
    read: &[bool],
) {
    let Some(size) = size else { return };
    let per_row = consumed as f64 / t_s.len() as f64;
    let rows = (size as f64 / per_row.max(1.0) * 1.02).min(MAX_ROWS as f64) as usize;
    let more = rows.saturating_sub(t_s.len());
    t_s.reserve_exact(more);
    for (v, _) in values.iter_mut().zip(read).filter(|(_, r)| **r) {
        v.reserve_exact(more);
    }
}

/// The error [`LineStarts`] raises past [`MAX_LINE_BYTES`]: the line.
#[derive(Debug)]
struct LineTooLong(u64);

impl fmt::Display for LineTooLong {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {} is longer than {MAX_LINE_BYTES} bytes", self.0)
    }
}

impl std::error::Error for LineTooLong {}

/// Read the next CSV record into `record`; `Ok(false)` at the end of input.
fn next_record<R: io::Read>(
    rdr: &mut csv::Reader<LineStarts<R>>,
    record: &mut csv::ByteRecord,
    file: &str,
) -> Result<bool, RunFileError> {
    rdr.read_byte_record(record).map_err(|e| {
        let message = e.to_string();
        match e.into_kind() {
            csv::ErrorKind::Io(source) => match source
                .get_ref()
                .and_then(|e| e.downcast_ref::<LineTooLong>())
            {
                Some(&LineTooLong(line)) => RunFileError::TooLarge {
                    file: file.to_owned(),
                    line,
                    what: format!("line longer than {MAX_LINE_BYTES} bytes"),
                },
                None => RunFileError::Io {
                    file: file.to_owned(),
                    source,
                },
            },
            // Not produced with byte records and `flexible`, but csv may add
            // kinds; report them rather than assume.
            _ => RunFileError::Csv {
                file: file.to_owned(),
                message,
            },
        }
    })
}

/// 1-based line on which `record`, just read from `rdr`, starts.
fn line_of<R: io::Read>(rdr: &mut csv::Reader<LineStarts<R>>, record: &csv::ByteRecord) -> u64 {
    let Some(position) = record.position() else {
        return 0; // Not produced by csv for records it reads.
    };
    rdr.get_mut()
        .line_at_or_after(position.byte())
        .unwrap_or(position.line())
}

/// Input wrapper that notes where each line with content starts.
///
/// csv's record positions are taken before it skips what precedes a record:
/// blank lines, and the `\n` of a CRLF ending the previous one. So
/// `position().line()` is one too low after a CRLF and after each blank line.
/// A record really starts at the first line start with content at or after
/// its position, and this wrapper, seeing every byte csv reads, can say which
/// line that is. Memory stays bounded as long as the line of every record is
/// asked for: entries behind it are then dropped, and csv reads only a buffer
/// ahead.
struct LineStarts<R> {
    inner: R,
    /// Bytes passed on so far.
    offset: u64,
    /// 1 + the number of line ends (`\n`, `\r\n` or a lone `\r`) passed
    /// on so far.
    line: u64,
    /// Whether the next byte starts a line.
    at_line_start: bool,
    /// Whether the last byte was `\r`, so a `\n` now ends no new line.
    after_cr: bool,
    /// (byte offset, line) of line starts with content, in input order.
    starts: VecDeque<(u64, u64)>,
    /// Bytes since the last line end, checked against [`MAX_LINE_BYTES`].
    line_bytes: u64,
}

impl<R> LineStarts<R> {
    fn new(inner: R) -> Self {
        LineStarts {
            inner,
            offset: 0,
            line: 1,
            at_line_start: true,
            after_cr: false,
            starts: VecDeque::new(),
            line_bytes: 0,
        }
    }

    /// Line of the first content line start at or after byte `offset`.
    /// Queries must come in increasing order of `offset`.
    fn line_at_or_after(&mut self, offset: u64) -> Option<u64> {
        while let Some(&(start, line)) = self.starts.front() {
            if start >= offset {
                return Some(line);
            }
            self.starts.pop_front();
        }
        None
    }
}

impl<R> LineStarts<R> {
    /// Notes the line ends and content line starts of `chunk`, which
    /// follows every byte seen so far. Jumps from line end to line end
    /// (memchr), so bytes inside a line cost nothing here.
    fn scan(&mut self, chunk: &[u8]) -> io::Result<()> {
        let mut at = 0;
        for end in memchr::memchr2_iter(b'\n', b'\r', chunk) {
            self.content(end - at)?;
            self.line_end(chunk[end]);
            at = end + 1;
        }
        self.content(chunk.len() - at)
    }

    /// `len` bytes of line content (no line end), starting at `self.offset`.
    fn content(&mut self, len: usize) -> io::Result<()> {
        if len == 0 {
            return Ok(());
        }
        if self.at_line_start {
            self.starts.push_back((self.offset, self.line));
        }
        self.at_line_start = false;
        self.after_cr = false;
        self.offset += len as u64;
        self.line_bytes += len as u64;
        self.check_line_length()
    }

    /// One line-end byte. csv ends a line at `\n`, `\r\n` and a lone `\r`
    /// (old Mac files); each counts once.
    fn line_end(&mut self, byte: u8) {
        if byte == b'\r' || !self.after_cr {
            self.line += 1;
        }
        self.at_line_start = true;
        self.line_bytes = 0;
        self.after_cr = byte == b'\r';
        self.offset += 1;
    }

    fn check_line_length(&self) -> io::Result<()> {
        if self.line_bytes > MAX_LINE_BYTES {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                LineTooLong(self.line),
            ));
        }
        Ok(())
    }
}

impl<R: io::Read> io::Read for LineStarts<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.scan(buf.get(..n).unwrap_or_default())?;
        Ok(n)
    }
}

/// The validated header: what every data row is checked against.
struct Header {
    /// All names in file order, `t_s` included, for naming cells in errors.
    names: Vec<String>,
    /// Names without `t_s`, in file order.
    columns: Vec<String>,
    /// 0-based field index of `t_s`.
    time_index: usize,
    /// Each name's physical quantity (file order), where its name says it.
    quantities: Vec<Option<Quantity>>,
}

impl Header {
    fn parse(record: &csv::ByteRecord, line: u64, file: &str) -> Result<Header, RunFileError> {
        let mut names = Vec::with_capacity(record.len());
        let mut seen: HashMap<String, usize> = HashMap::with_capacity(record.len());
        for (index, raw) in record.iter().enumerate() {
            let column = index + 1;
            // csv strips a BOM at the very start of the input; this also
            // covers one it could not see (e.g. split across reads).
            let raw = if index == 0 {
                raw.strip_prefix(UTF8_BOM).unwrap_or(raw)
            } else {
                raw
            };
            let name = String::from_utf8(clean_field(raw).into_owned()).map_err(|_| {
                RunFileError::HeaderNotUtf8 {
                    file: file.to_owned(),
                    line,
                    column,
                }
            })?;
            if name.is_empty() {
                return Err(RunFileError::EmptyColumnName {
                    file: file.to_owned(),
                    line,
                    column,
                });
            }
            if let Some(&first) = seen.get(&name) {
                return Err(RunFileError::DuplicateColumn {
                    file: file.to_owned(),
                    line,
                    name,
                    first,
                    second: column,
                });
            }
            seen.insert(name.clone(), column);
            names.push(name);
        }
        let Some(time_index) = names.iter().position(|n| n == TIME_COLUMN) else {
            // One column holding `;` or a tab: another separator, likely.
            let separator = match names.as_slice() {
                [only] => [';', '\t'].into_iter().find(|c| only.contains(*c)),
                _ => None,
            };
            return Err(RunFileError::NoTimeColumn {
                file: file.to_owned(),
                line,
                separator,
            });
        };
        let columns = names
            .iter()
            .enumerate()
            .filter(|&(i, _)| i != time_index)
            .map(|(_, n)| n.clone())
            .collect();
        let quantities = names.iter().map(|n| Quantity::of(n)).collect();
        Ok(Header {
            names,
            columns,
            time_index,
            quantities,
        })
    }

    /// Check and convert one data row: its time is returned and its other
    /// values are left in `row` (in column order). `previous` is the time of
    /// the last row kept. All-or-nothing: on error the caller drops `row`.
    fn parse_row(
        &self,
        record: &csv::ByteRecord,
        previous: Option<f64>,
        read: &[bool],
        row: &mut Vec<Option<f64>>,
    ) -> Result<f64, RowErrorKind> {
        if record.len() != self.names.len() {
            return Err(RowErrorKind::FieldCount {
                expected: self.names.len(),
                found: record.len(),
            });
        }
        row.clear();
        let mut time = None;
        let mut data_index = 0;
        for (index, (raw, name)) in record.iter().zip(&self.names).enumerate() {
            let column = index + 1;
            let wanted = index == self.time_index || read.get(data_index).copied().unwrap_or(true);
            if index != self.time_index {
                data_index += 1;
            }
            let value = if wanted {
                let v = parse_cell(raw, column, name)?;
                if let (Some(x), Some(q)) = (v, self.quantities.get(index).copied().flatten()) {
                    q.check(x, column, name, || shown_cell(clean_field(raw).as_ref()))?;
                }
                v
            } else {
                None
            };
            if index == self.time_index {
                time = Some(value.ok_or(RowErrorKind::MissingTime { column })?);
            } else {
                row.push(value);
            }
        }
        let column = self.time_index + 1;
        // The field count matched, so the time field was seen; stay total anyway.
        let time = time.ok_or(RowErrorKind::MissingTime { column })?;
        match previous {
            Some(previous) if time <= previous => Err(RowErrorKind::TimeNotIncreasing {
                column,
                time,
                previous,
            }),
            _ => Ok(time),
        }
    }
}

/// Header rules of [`RunFile::from_columns`]: no empty, duplicate or
/// `t_s` name among the data columns (the header is line 1).
fn check_names(file: &str, columns: &[(String, Option<Vec<f64>>)]) -> Result<(), RunFileError> {
    for (i, (name, _)) in columns.iter().enumerate() {
        if name.trim().is_empty() {
            return Err(RunFileError::EmptyColumnName {
                file: file.to_owned(),
                line: 1,
                column: i + 2,
            });
        }
        let first = if name == TIME_COLUMN {
            Some(0)
        } else {
            columns[..i]
                .iter()
                .position(|(n, _)| n == name)
                .map(|j| j + 2)
        };
        if let Some(first) = first {
            return Err(RunFileError::DuplicateColumn {
                file: file.to_owned(),
                line: 1,
                name: name.clone(),
                first: first.max(1),
                second: i + 2,
            });
        }
    }
    Ok(())
}

/// A physical quantity a column's name states (CONTRACT.md section 2:
/// "units are in the names"), with the range no reading of it can leave:
/// a cell outside is a broken reading or a wrong column, refused where it
/// stands rather than taken as a figure (a single `1e14` in `dz_um` was
/// `diagnose`'s gap; in `T1`, a fit's largest input).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// `T1`, `T2`, ... and `*_c`: deg C, from absolute zero to
    /// [`MAX_TEMPERATURE_C`].
    Temperature,
    /// `*_um` and the probes `S1`, `S2`, ...: um, at most
    /// [`MAX_LENGTH_UM`] in magnitude.
    Length,
}

/// The warmest reading a run file may hold, deg C: above a PT100's or
/// PT1000's range (850 C) and far above any machine tool's.
pub const MAX_TEMPERATURE_C: f64 = 1000.0;
/// Absolute zero, deg C.
pub const ABSOLUTE_ZERO_C: f64 = -273.15;
/// The largest length a run file may hold, um: 10 m, longer than any
/// machine's travel and 10^5 times any thermal drift.
pub const MAX_LENGTH_UM: f64 = 1e7;

impl Quantity {
    /// The quantity `name` states, if any.
    pub fn of(name: &str) -> Option<Quantity> {
        if is_temperature_column(name) || name.ends_with("_c") {
            Some(Quantity::Temperature)
        } else if numbered(name, 'S') || name.ends_with("_um") {
            Some(Quantity::Length)
        } else {
            None
        }
    }

    /// The closed range a reading lies in.
    pub fn range(self) -> (f64, f64) {
        match self {
            Quantity::Temperature => (ABSOLUTE_ZERO_C, MAX_TEMPERATURE_C),
            Quantity::Length => (-MAX_LENGTH_UM, MAX_LENGTH_UM),
        }
    }

    /// Whether a reading `v` lies in [`Quantity::range`].
    pub fn admits(self, v: f64) -> bool {
        let (lo, hi) = self.range();
        (lo..=hi).contains(&v)
    }

    /// The quantity and its unit as messages name them.
    pub fn what(self) -> &'static str {
        match self {
            Quantity::Temperature => "a temperature in deg C",
            Quantity::Length => "a length in um",
        }
    }

    /// `v` if it lies in [`Quantity::range`]; else the cell's error, its
    /// text from `text`.
    fn check(
        self,
        v: f64,
        column: usize,
        name: &str,
        text: impl FnOnce() -> String,
    ) -> Result<(), RowErrorKind> {
        if self.admits(v) {
            Ok(())
        } else {
            Err(RowErrorKind::Unphysical {
                column,
                name: name.to_owned(),
                text: text(),
                quantity: self,
            })
        }
    }
}

/// Checks one in-memory cell: `NaN` is a missing value (stored as is, see
/// [`cells`]), any other non-finite or too large value an error (as
/// [`parse_cell`] judges a CSV cell), as is a value its name's quantity
/// cannot take.
fn check_memory_cell(v: f64, column: usize, name: &str) -> Result<(), RowErrorKind> {
    if v.is_nan() {
        Ok(())
    } else if !v.is_finite() {
        Err(RowErrorKind::NotFinite {
            column,
            name: name.to_owned(),
            text: format!("{v}"),
        })
    } else if v.abs() > MAX_CELL_MAGNITUDE {
        Err(RowErrorKind::OutOfRange {
            column,
            name: name.to_owned(),
            text: format!("{v}"),
        })
    } else if let Some(q) = Quantity::of(name) {
        q.check(v, column, name, || format!("{v}"))
    } else {
        Ok(())
    }
}

/// Largest magnitude a cell may hold. Beyond it a value is a logger's fill
/// or overflow code, not a measurement, and its square (variances, norms)
/// would overflow f64: a single -1e308 made the target's variance infinite
/// and `select` call the target constant. 1e15 still takes epoch times in
/// microseconds (1.7e15 in 2023 would not: seconds or milliseconds do).
pub const MAX_CELL_MAGNITUDE: f64 = 1e15;

// Every column of a `RunFile` can be centred and scaled without overflow:
// at most `MAX_CELLS` cells, each at most `MAX_CELL_MAGNITUDE` from zero and
// so at most twice that from the column's mean, have a centred sum of
// squares of at most 4e38, far inside f64. So nothing that fits, ranks or
// aligns run-file columns needs an overflow check.
const _: () =
    assert!((MAX_CELLS as f64) * (2.0 * MAX_CELL_MAGNITUDE) * (2.0 * MAX_CELL_MAGNITUDE) < 1e300);

/// Parse one cell: blank (after trimming) is `None`; otherwise it must be a
/// finite number in Rust's float syntax (which accepts `1`, `-1.5`, `.5`,
/// `1e-3`, ...) of magnitude at most [`MAX_CELL_MAGNITUDE`].
fn parse_cell(raw: &[u8], column: usize, name: &str) -> Result<Option<f64>, RowErrorKind> {
    let cell = clean_field(raw);
    let cell = cell.as_ref();
    if cell.is_empty() {
        return Ok(None);
    }
    match parse_f64(cell) {
        Ok(Ok(v)) if v.is_finite() && v.abs() <= MAX_CELL_MAGNITUDE => Ok(Some(v)),
        Ok(Ok(v)) if v.is_finite() => Err(RowErrorKind::OutOfRange {
            column,
            name: name.to_owned(),
            text: shown_cell(cell),
        }),
        Ok(Ok(_)) => Err(RowErrorKind::NotFinite {
            column,
            name: name.to_owned(),
            text: shown_cell(cell),
        }),
        _ => Err(RowErrorKind::BadNumber {
            column,
            name: name.to_owned(),
            text: shown_cell(cell),
        }),
    }
}

/// A cell's number in Rust's float syntax: fast-float2 (the Eisel-Lemire
/// algorithm std uses too, without the UTF-8 check and the `&str` detour)
/// for what it reads; std's parser decides the rest, so what is accepted and
/// the value read are std's (test `fast_float_agrees_with_std`).
fn parse_f64(cell: &[u8]) -> Result<Result<f64, std::num::ParseFloatError>, std::str::Utf8Error> {
    match fast_float2::parse::<f64, _>(cell) {
        Ok(v) => Ok(Ok(v)),
        Err(_) => std::str::from_utf8(cell).map(str::parse::<f64>),
    }
}

/// A field as meant: surrounding whitespace trimmed, and quotes removed from
/// a field like ` "T1"`. csv takes quotes as quoting only when they open the
/// field, but writers that put a space after each comma are common enough
/// that ` "1.5"` should read as `1.5`, not fail.
fn clean_field(raw: &[u8]) -> Cow<'_, [u8]> {
    let field = raw.trim_ascii();
    let had_leading_space =
        field.len() < raw.len() && raw.first().is_some_and(u8::is_ascii_whitespace);
    let quoted = had_leading_space
        .then(|| field.strip_prefix(b"\"")?.strip_suffix(b"\""))
        .flatten();
    let Some(inner) = quoted else {
        return Cow::Borrowed(field);
    };
    let inner = inner.trim_ascii();
    if !inner.windows(2).any(|w| w == b"\"\"") {
        return Cow::Borrowed(inner);
    }
    let mut unescaped = Vec::with_capacity(inner.len());
    let mut bytes = inner.iter().copied().peekable();
    while let Some(byte) = bytes.next() {
        unescaped.push(byte);
        if byte == b'"' && bytes.peek() == Some(&b'"') {
            bytes.next();
        }
    }
    Cow::Owned(unescaped)
}

/// A column name as shown in a message: as is, unless it holds control
/// characters (a newline in a quoted header cell), which are escaped to keep
/// the message on one line.
struct Name<'a>(&'a str);

/// `s` as a message shows it on one line: as is, or quoted with its control
/// characters escaped if it has any (a file name holding a line break).
pub fn printable(s: &str) -> String {
    Name(s).to_string()
}

impl fmt::Display for Name<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.chars().any(char::is_control) {
            write!(f, "{:?}", self.0)
        } else {
            f.write_str(self.0)
        }
    }
}

/// Cell text as shown in a message: lossily decoded and cut short.
fn shown_cell(cell: &[u8]) -> String {
    let text = String::from_utf8_lossy(cell);
    if text.chars().count() <= MAX_SHOWN_CELL_CHARS {
        text.into_owned()
    } else {
        let mut short: String = text.chars().take(MAX_SHOWN_CELL_CHARS).collect();
        short.push('…');
        short
    }
}

/// Why a run file could not be read. Each variant displays as one line that
/// names the file (and, where it applies, the line and column), so the CLI
/// can print it as is.
///
/// No variant reports a [`std::error::Error::source`]: the underlying cause is
/// already in the message, and reporting it again would print it twice in
/// error chains. The I/O error itself stays available in
/// [`RunFileError::Io`].
#[derive(Debug)]
#[non_exhaustive]
pub enum RunFileError {
    /// The file could not be opened or read.
    Io {
        /// File name as given.
        file: String,
        /// The operating system's error.
        source: io::Error,
    },
    /// A CSV-level error other than I/O (not expected with this reader's
    /// settings; kept so a future csv version cannot make it a panic).
    Csv {
        /// File name as given.
        file: String,
        /// csv's message.
        message: String,
    },
    /// The input is empty: not even a header row.
    EmptyFile {
        /// File name as given.
        file: String,
    },
    /// The header has no `t_s` column.
    NoTimeColumn {
        /// File name as given.
        file: String,
        /// Line of the header.
        line: u64,
        /// The separator a header without commas seems to use (`;`, tab).
        separator: Option<char>,
    },
    /// A header name is empty (often a trailing comma).
    EmptyColumnName {
        /// File name as given.
        file: String,
        /// Line of the header.
        line: u64,
        /// 1-based field index of the empty name.
        column: usize,
    },
    /// Two header names are equal, so a column could not be told apart.
    DuplicateColumn {
        /// File name as given.
        file: String,
        /// Line of the header.
        line: u64,
        /// The repeated name.
        name: String,
        /// 1-based field index of its first occurrence.
        first: usize,
        /// 1-based field index of its second occurrence.
        second: usize,
    },
    /// A header name is not UTF-8 text (typically a UTF-16 file).
    HeaderNotUtf8 {
        /// File name as given.
        file: String,
        /// Line of the header.
        line: u64,
        /// 1-based field index.
        column: usize,
    },
    /// A data row is bad and rows are not being skipped.
    Row(RowError),
    /// The file is beyond a size limit ([`MAX_LINE_BYTES`],
    /// [`MAX_COLUMNS`], [`MAX_ROWS`], [`MAX_CELLS`]): most likely not a run
    /// file at all.
    TooLarge {
        /// File name as given.
        file: String,
        /// Line at which the limit was passed.
        line: u64,
        /// Which limit, in words.
        what: String,
    },
    /// The file has a header but no usable data row.
    NoDataRows {
        /// File name as given.
        file: String,
        /// How many rows were skipped as bad (0 if there were none at all).
        skipped: usize,
        /// The first skipped row's error, to hint at what went wrong.
        first_skipped: Option<Box<RowError>>,
    },
}

impl fmt::Display for RunFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { file, source } => write!(f, "cannot read {file}: {source}"),
            Self::Csv { file, message } => write!(f, "{file}: {message}"),
            Self::EmptyFile { file } => write!(f, "{file}: empty file (no header row)"),
            Self::NoTimeColumn {
                file,
                line,
                separator,
            } => {
                write!(f, "{file}:{line}: no {TIME_COLUMN} column in the header")?;
                match separator {
                    Some(c) => write!(
                        f,
                        " (it has no comma but {}: run files are comma-separated)",
                        if *c == '\t' { "tabs" } else { "semicolons" }
                    ),
                    None => Ok(()),
                }
            }
            Self::EmptyColumnName { file, line, column } => {
                write!(f, "{file}:{line}: column {column} has an empty name")
            }
            Self::DuplicateColumn {
                file,
                line,
                name,
                first,
                second,
            } => write!(
                f,
                "{file}:{line}: duplicate column name {name:?} (columns {first} and {second})"
            ),
            Self::HeaderNotUtf8 { file, line, column } => write!(
                f,
                "{file}:{line}: name of column {column} is not UTF-8 text (save the file as UTF-8)"
            ),
            Self::Row(e) => e.fmt(f),
            Self::TooLarge { file, line, what } => {
                write!(f, "{file}:{line}: {what} (not a run file?)")
            }
            Self::NoDataRows {
                file,
                skipped,
                first_skipped,
            } => match first_skipped {
                Some(first) => write!(
                    f,
                    "{file}: no valid data rows (all {skipped} skipped; first: {first})"
                ),
                None => write!(f, "{file}: no data rows"),
            },
        }
    }
}

impl std::error::Error for RunFileError {}

/// An error in one data row: fatal by default, recorded in
/// [`RunFile::skipped`] with [`ReadOptions::skip_bad_rows`].
#[derive(Debug, Clone, PartialEq)]
pub struct RowError {
    /// File name as given.
    pub file: String,
    /// 1-based line where the row starts (the header is line 1).
    pub line: u64,
    /// What is wrong.
    pub kind: RowErrorKind,
}

/// What is wrong with a data row. Columns are 1-based field indices, as a
/// spreadsheet or editor would count them.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum RowErrorKind {
    /// The row does not have one field per header name.
    FieldCount {
        /// Number of header names.
        expected: usize,
        /// Number of fields in the row.
        found: usize,
    },
    /// A cell is neither empty nor a number.
    BadNumber {
        /// 1-based field index.
        column: usize,
        /// Header name of the column.
        name: String,
        /// The cell's text (shortened if long).
        text: String,
    },
    /// A cell is a number but not a finite one (`nan`, `inf`, or an overflow
    /// such as `1e999`), which no model can use.
    NotFinite {
        /// 1-based field index.
        column: usize,
        /// Header name of the column.
        name: String,
        /// The cell's text (shortened if long).
        text: String,
    },
    /// A cell's magnitude exceeds [`MAX_CELL_MAGNITUDE`].
    OutOfRange {
        /// 1-based field index.
        column: usize,
        /// Header name of the column.
        name: String,
        /// The cell's text (shortened if long).
        text: String,
    },
    /// A cell outside the range of the quantity its column's name states.
    Unphysical {
        /// 1-based field index.
        column: usize,
        /// Header name of the column.
        name: String,
        /// The cell's text (shortened if long).
        text: String,
        /// The quantity the name states.
        quantity: Quantity,
    },
    /// The `t_s` cell is empty.
    MissingTime {
        /// 1-based field index of `t_s`.
        column: usize,
    },
    /// The time is not after the previous row's (the previous row kept, when
    /// rows are skipped).
    TimeNotIncreasing {
        /// 1-based field index of `t_s`.
        column: usize,
        /// This row's time.
        time: f64,
        /// The previous row's time.
        previous: f64,
    },
}

impl fmt::Display for RowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Self { file, line, kind } = self;
        match kind {
            RowErrorKind::FieldCount { expected, found } => {
                write!(f, "{file}:{line}: expected {expected} fields, found {found}")
            }
            RowErrorKind::BadNumber { column, name, text } => write!(
                f,
                "{file}:{line}:{column} ({}): cannot parse {text:?} as a number",
                Name(name)
            ),
            RowErrorKind::NotFinite { column, name, text } => {
                write!(
                    f,
                    "{file}:{line}:{column} ({}): value {text:?} is not finite",
                    Name(name)
                )
            }
            RowErrorKind::OutOfRange { column, name, text } => {
                write!(
                    f,
                    "{file}:{line}:{column} ({}): value {text:?} is beyond {MAX_CELL_MAGNITUDE:e} in magnitude",
                    Name(name)
                )
            }
            RowErrorKind::Unphysical {
                column,
                name,
                text,
                quantity,
            } => {
                let (lo, hi) = quantity.range();
                write!(
                    f,
                    "{file}:{line}:{column} ({}): value {text:?} is not {} (its name says \
                     so; readings lie in {lo} ..= {hi})",
                    Name(name),
                    quantity.what()
                )
            }
            RowErrorKind::MissingTime { column } => {
                write!(f, "{file}:{line}:{column} ({TIME_COLUMN}): missing time")
            }
            RowErrorKind::TimeNotIncreasing {
                column,
                time,
                previous,
            } => write!(
                f,
                "{file}:{line}:{column} ({TIME_COLUMN}): time {} is not after the previous row's time {}",
                Num(*time),
                Num(*previous)
            ),
        }
    }
}

impl std::error::Error for RowError {}

/// Linear interpolation of a column sampled at `t` onto `grid`; gaps (None)
/// are bridged linearly between the neighbouring valid samples; grid points
/// before the first or after the last valid sample give None.
///
/// This is how runs with different or irregular sampling are put on one time
/// base. It never extrapolates, because an invented temperature at the edge of
/// a run is worse than an honest gap. A grid point equal to a sample time gets
/// that sample's value exactly.
///
/// One sweep over both inputs, O(`t.len()` + `grid.len()`), which requires `t`
/// strictly increasing (as in a [`RunFile`]) and `grid` ascending. Never
/// panics: samples with a non-finite time or value count as missing, a
/// non-finite grid point or one that goes back in time gives `None`, and if
/// `t` and `x` differ in length the extra entries of the longer are ignored.
pub fn resample_linear(
    t: &[f64],
    x: impl IntoIterator<Item = Option<f64>>,
    grid: &[f64],
) -> Vec<Option<f64>> {
    let mut valid = t.iter().zip(x).filter_map(|(&t, x)| match x {
        Some(x) if t.is_finite() && x.is_finite() => Some((t, x)),
        _ => None,
    });
    // Invariant after advancing: `before.0 <= g < after.0`.
    let mut before: Option<(f64, f64)> = None;
    let mut after = valid.next();
    grid.iter()
        .map(|&g| {
            if !g.is_finite() {
                return None;
            }
            while let Some(sample) = after.filter(|&(ta, _)| ta <= g) {
                before = Some(sample);
                after = valid.next();
            }
            interpolate_between(before, after, g)
        })
        .collect()
}

/// The value at `g` of the line through the valid samples `before` (the
/// last at or before `g`) and `after` (the first after it): `None` without
/// a sample at or before `g`, or without one after it unless `before` lies
/// exactly on `g`. [`resample_linear`]'s rule, also used by the streamed
/// resampling (`stream::regrid`), so both give the same value to the bit.
pub fn interpolate_between(
    before: Option<(f64, f64)>,
    after: Option<(f64, f64)>,
    g: f64,
) -> Option<f64> {
    let (t0, x0) = before.filter(|&(t0, _)| t0 <= g)?;
    if t0 == g {
        return Some(x0);
    }
    let (t1, x1) = after?;
    let w = (g - t0) / (t1 - t0);
    // This form, unlike `x0 + w * (x1 - x0)`, cannot overflow for
    // finite inputs of opposite sign.
    Some(x0 * (1.0 - w) + x1 * w).filter(|v| v.is_finite())
}

/// The uniform grid t0, t0+dt, ... up to and including the last time <= t_end
/// (guard dt <= 0/non-finite and absurd sizes with an error, e.g. > 10 million
/// points).
///
/// The time base onto which runs are resampled for fitting and evaluation.
/// Points are computed as `t0 + k*dt`, not by repeated addition, so they do not
/// drift. A point within `1e-9 * dt` of `t_end` counts as reaching it and is
/// set to `t_end` exactly: `uniform_grid(0.0, 0.3, 0.1)` has 4 points ending
/// at `0.3`, as intended, rather than 3 because `0.3 / 0.1` rounds to
/// `2.9999999999999996`; and a grid spanning a run's own times never ends a
/// hair after its last sample (where [`resample_linear`] would give `None`).
/// `t_end == t0` gives the single point `t0`.
pub fn uniform_grid(t0: f64, t_end: f64, dt: f64) -> Result<Vec<f64>, GridError> {
    let n = uniform_grid_len(t0, t_end, dt)?;
    Ok((0..n).map(|k| (t0 + k as f64 * dt).min(t_end)).collect())
}

/// The number of points of [`uniform_grid`]`(t0, t_end, dt)` (same checks),
/// for callers that compute point `k` as `(t0 + k dt).min(t_end)` as they go.
pub fn uniform_grid_len(t0: f64, t_end: f64, dt: f64) -> Result<usize, GridError> {
    if !(t0.is_finite() && t_end.is_finite()) {
        return Err(GridError::NotFinite { t0, t_end });
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(GridError::BadStep { dt });
    }
    if t_end < t0 {
        return Err(GridError::EndBeforeStart { t0, t_end });
    }
    // Not NaN (finite bounds, t_end >= t0, dt > 0) but possibly infinite if
    // the span overflows, or huge: compare before converting.
    let last_k = ((t_end - t0) / dt + 1e-9).floor();
    if last_k >= MAX_GRID_POINTS as f64 {
        return Err(GridError::TooManyPoints { t0, t_end, dt });
    }
    // Below this, neighbouring points could round to the same value.
    let scale = t0.abs().max(t_end.abs());
    if dt < scale * 1e-14 {
        return Err(GridError::StepTooSmall { t0, t_end, dt });
    }
    // In range 0..MAX_GRID_POINTS by the checks above, so the cast is exact.
    Ok(last_k as usize + 1)
}

/// Why [`uniform_grid`] refused to build a grid. These are caller mistakes
/// (wrong units, swapped arguments), reported rather than turned into an empty
/// or gigantic grid.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum GridError {
    /// The start or end is NaN or infinite.
    NotFinite {
        /// Requested start, s.
        t0: f64,
        /// Requested end, s.
        t_end: f64,
    },
    /// The step is zero, negative, NaN or infinite.
    BadStep {
        /// Requested step, s.
        dt: f64,
    },
    /// The end is before the start.
    EndBeforeStart {
        /// Requested start, s.
        t0: f64,
        /// Requested end, s.
        t_end: f64,
    },
    /// The step is too small for the magnitude of the times to give distinct
    /// points.
    StepTooSmall {
        /// Requested start, s.
        t0: f64,
        /// Requested end, s.
        t_end: f64,
        /// Requested step, s.
        dt: f64,
    },
    /// The grid would have more than [`MAX_GRID_POINTS`] points.
    TooManyPoints {
        /// Requested start, s.
        t0: f64,
        /// Requested end, s.
        t_end: f64,
        /// Requested step, s.
        dt: f64,
    },
    /// The grid would be mostly interpolation: more than
    /// [`Sampling::MAX_POINTS_PER_ROW`] points per row of the run
    /// ([`Sampling::check_grid`]).
    MostlyInterpolated {
        /// Rows of the run.
        rows: usize,
        /// Points the grid would have.
        points: usize,
        /// Requested step, s.
        dt: f64,
        /// The run's longest and median steps between rows, s (`None`:
        /// one row).
        gap: Option<f64>,
        /// See `gap`.
        median: Option<f64>,
    },
}

impl fmt::Display for GridError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::NotFinite { t0, t_end } => write!(
                f,
                "time grid bounds must be finite, got {} s to {} s",
                Num(t0),
                Num(t_end)
            ),
            Self::BadStep { dt } => write!(
                f,
                "time grid step must be a positive finite number of seconds, got {}",
                Num(dt)
            ),
            Self::EndBeforeStart { t0, t_end } => write!(
                f,
                "time grid end {} s is before its start {} s",
                Num(t_end),
                Num(t0)
            ),
            Self::StepTooSmall { t0, t_end, dt } => write!(
                f,
                "time grid step {} s is too small for times {} s to {} s",
                Num(dt),
                Num(t0),
                Num(t_end)
            ),
            Self::TooManyPoints { t0, t_end, dt } => write!(
                f,
                "time grid from {} s to {} s every {} s would exceed {MAX_GRID_POINTS} points",
                Num(t0),
                Num(t_end),
                Num(dt)
            ),
            Self::MostlyInterpolated {
                rows,
                points,
                dt,
                gap,
                median,
            } => {
                write!(
                    f,
                    "{rows} rows resampled every {} s would make {points} points, \
                     more than {} per row: ",
                    Num(dt),
                    Sampling::MAX_POINTS_PER_ROW
                )?;
                let per_row = Sampling::MAX_POINTS_PER_ROW as f64;
                match (gap, median) {
                    (Some(gap), Some(median)) if gap > per_row * median => write!(
                        f,
                        "the longest step between rows is {} s (the median {} s); \
                         a run with a gap that long is two runs: split the file there",
                        Num(gap),
                        Num(median)
                    ),
                    (_, Some(median)) => write!(
                        f,
                        "a model step of {} s is too fine for rows {} s apart",
                        Num(dt),
                        Num(median)
                    ),
                    _ => write!(f, "a model step of {} s is too fine for this run", Num(dt)),
                }
            }
        }
    }
}

impl std::error::Error for GridError {}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    const STRICT: ReadOptions = ReadOptions {
        skip_bad_rows: false,
        only: None,
    };
    const SKIP: ReadOptions = ReadOptions {
        skip_bad_rows: true,
        only: None,
    };

    fn read_str(csv: &str, opts: &ReadOptions) -> Result<RunFile, RunFileError> {
        RunFile::from_reader("run.csv", csv.as_bytes(), opts)
    }

    #[test]
    fn fast_float_agrees_with_std() {
        // Every spelling a logger or a spreadsheet writes, and the near
        // misses: the fast path must accept exactly what std accepts, with
        // the same bits (exact: both round correctly).
        let cells = [
            "0",
            "-0",
            "+1",
            "1.",
            ".5",
            "-.5",
            "1e3",
            "1E-3",
            "1e+3",
            "2.5e-308",
            "1.7976931348623157e308",
            "4.9e-324",
            "123456789012345678901234567890",
            "0.1",
            "25.7574",
            "-8.5443",
            "1e",
            "1e+",
            "e3",
            ".",
            "-",
            "+",
            "",
            "1.2.3",
            "1,5",
            "0x10",
            "1_000",
            "inf",
            "-inf",
            "Infinity",
            "NaN",
            "nan",
            "infinity",
            "in",
            "1e400",
            "-1e400",
            " 1",
            "1 ",
            "١",
            "1d3",
            "00001.5000",
        ];
        for c in cells {
            let fast = parse_f64(c.as_bytes()).ok().and_then(Result::ok);
            let std = c.parse::<f64>().ok();
            assert_eq!(
                fast.map(|v| (v.is_nan(), if v.is_nan() { 0 } else { v.to_bits() })),
                std.map(|v| (v.is_nan(), if v.is_nan() { 0 } else { v.to_bits() })),
                "{c:?}"
            );
        }
    }

    #[test]
    fn line_numbers_hold_across_read_chunks() {
        // LineStarts sees the input in the chunks csv asks for: a CRLF or a
        // blank line split across two reads must count once. One byte per
        // read is the hardest split.
        struct OneByte<'a>(&'a [u8]);
        impl io::Read for OneByte<'_> {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                let Some((&b, rest)) = self.0.split_first() else {
                    return Ok(0);
                };
                buf[0] = b;
                self.0 = rest;
                Ok(1)
            }
        }
        let csv = b"t_s,T1\r\n0,1\r\n\r\n1,2\r\r2,x\n";
        let e = RunFile::from_reader("run.csv", OneByte(csv), &STRICT).unwrap_err();
        assert!(e.to_string().starts_with("run.csv:6:"), "{e}");
        let whole = read_str(std::str::from_utf8(csv).unwrap(), &STRICT).unwrap_err();
        assert_eq!(e.to_string(), whole.to_string());
    }

    /// The strict reader's error message for `csv`.
    fn error(csv: &str) -> String {
        match read_str(csv, &STRICT) {
            Ok(run) => panic!("expected an error, read {} rows", run.len()),
            Err(e) => e.to_string(),
        }
    }

    fn col(run: &RunFile, name: &str) -> Vec<Option<f64>> {
        run.column(name).expect("column exists").to_options()
    }

    #[test]
    fn reads_values_empty_cells_and_unknown_columns() {
        let run = read_str("t_s,T1,mystery\n0,1.5,\n15,,-2e-3\n30,3,7\n", &STRICT).unwrap();
        assert_eq!(run.path, PathBuf::from("run.csv"));
        assert_eq!(run.columns, ["T1", "mystery"]);
        assert_eq!(run.t_s, [0.0, 15.0, 30.0]);
        assert_eq!(run.len(), 3);
        assert!(!run.is_empty());
        assert_eq!(col(&run, "T1"), [Some(1.5), None, Some(3.0)]);
        assert_eq!(col(&run, "mystery"), [None, Some(-2e-3), Some(7.0)]);
        assert!(run.has_column("mystery"));
        assert!(!run.has_column("t_s"));
        assert!(!run.has_column("T2"));
        assert_eq!(run.column("T2"), None);
        let names: Vec<&str> = run.iter_columns().map(|(n, _)| n).collect();
        assert_eq!(names, ["T1", "mystery"]);
        assert!(run.skipped.is_empty());
    }

    #[test]
    fn time_column_need_not_be_first() {
        let run = read_str("T1,t_s\n5,0\n6,1\n", &STRICT).unwrap();
        assert_eq!(run.columns, ["T1"]);
        assert_eq!(run.t_s, [0.0, 1.0]);
        assert_eq!(col(&run, "T1"), [Some(5.0), Some(6.0)]);
        assert_eq!(
            error("T1,t_s\n5,0\n6,\n"),
            "run.csv:3:2 (t_s): missing time"
        );
    }

    #[test]
    fn io_error_message() {
        let err = RunFile::read(Path::new("no_such_dir/run.csv"), &STRICT).unwrap_err();
        assert_eq!(
            err.to_string(),
            "cannot read no_such_dir/run.csv: No such file or directory (os error 2)"
        );
        assert!(matches!(err, RunFileError::Io { .. }));
    }

    #[test]
    fn bad_cell_message() {
        assert_eq!(
            error("t_s,T1,T2\n0,1,2\n15,1,abc\n"),
            r#"run.csv:3:3 (T2): cannot parse "abc" as a number"#
        );
        assert_eq!(
            error("t_s,T1\nx,1\n"),
            r#"run.csv:2:1 (t_s): cannot parse "x" as a number"#
        );
        // A decimal comma is a parse error, not a silently wrong value.
        assert_eq!(
            error("t_s,T1\n0,\"1,5\"\n"),
            r#"run.csv:2:2 (T1): cannot parse "1,5" as a number"#
        );
        // Quotes in the cell are escaped so the message stays unambiguous.
        assert_eq!(
            error("t_s,T1\n0,\"a\"\"b\"\n"),
            r#"run.csv:2:2 (T1): cannot parse "a\"b" as a number"#
        );
    }

    #[test]
    fn long_cell_is_shortened_in_message() {
        let junk = "y".repeat(1000);
        assert_eq!(
            error(&format!("t_s,T1\n0,{junk}\n")),
            format!(
                "run.csv:2:2 (T1): cannot parse \"{}…\" as a number",
                "y".repeat(MAX_SHOWN_CELL_CHARS)
            )
        );
    }

    #[test]
    fn invalid_utf8_cell_is_a_bad_number() {
        let err = RunFile::from_reader("run.csv", &b"t_s,T1\n0,\xFF\n"[..], &STRICT).unwrap_err();
        assert_eq!(
            err.to_string(),
            "run.csv:2:2 (T1): cannot parse \"\u{FFFD}\" as a number"
        );
    }

    #[test]
    fn non_finite_messages() {
        for text in ["inf", "-inf", "NaN", "infinity", "1e999"] {
            assert_eq!(
                error(&format!("t_s,T1,T2\n0,1,{text}\n")),
                format!("run.csv:2:3 (T2): value \"{text}\" is not finite")
            );
        }
        assert_eq!(
            error("t_s,T1\nnan,1\n"),
            r#"run.csv:2:1 (t_s): value "nan" is not finite"#
        );
    }

    /// Issue 14: one -1e308 cell overflowed the target's variance and
    /// `select` said "the target is constant"; it is now refused where it is.
    #[test]
    fn absurd_magnitudes_are_refused_where_they_are() {
        assert_eq!(
            error("t_s,T1,dz_um\n0,1,2\n1,1,-1e308\n"),
            r#"run.csv:3:3 (dz_um): value "-1e308" is beyond 1e15 in magnitude"#
        );
        // Epoch seconds and large values of a column without a unit still read.
        RunFile::from_reader("run.csv", &b"t_s,load\n1700000000,-1e9\n"[..], &STRICT).unwrap();
    }

    /// A temperature below absolute zero or above 1000 C, a length beyond
    /// 10 m: refused at the cell, by the quantity the name states; columns
    /// whose names state none (`speed_rpm`, `load`) are not judged.
    #[test]
    fn readings_their_quantity_cannot_take_are_refused_where_they_are() {
        assert_eq!(
            error("t_s,T1,dz_um\n0,1,2\n1,1,1e14\n"),
            "run.csv:3:3 (dz_um): value \"1e14\" is not a length in um (its name says so; \
             readings lie in -10000000 ..= 10000000)"
        );
        assert_eq!(
            error("t_s,T12,dz_um\n0,-273.2,2\n"),
            "run.csv:2:2 (T12): value \"-273.2\" is not a temperature in deg C (its name \
             says so; readings lie in -273.15 ..= 1000)"
        );
        assert!(error("t_s,coolant_c\n0,1000.5\n").contains("(coolant_c): value \"1000.5\" is not"));
        assert!(error("t_s,S5\n0,-2e7\n").contains("(S5): value \"-2e7\" is not a length"));
        let edge = "t_s,T1,ambient_c,S1,dz_um,Tx,T,speed_rpm\n\
                    0,-273.15,1000,1e7,-1e7,5000,5000,1e12\n";
        RunFile::from_reader("run.csv", edge.as_bytes(), &STRICT).unwrap();
        // In memory too (the Python binding's data frames).
        let e = RunFile::from_columns("df", vec![0.0], vec![("T3".into(), Some(vec![2e3]))]);
        assert!(format!("{}", e.unwrap_err()).contains("(T3): value \"2000\" is not a temperature"));
        // Quantities from names.
        assert_eq!(Quantity::of("T07"), Some(Quantity::Temperature));
        assert_eq!(Quantity::of("Tool"), None);
        assert_eq!(Quantity::of("ch1_um"), Some(Quantity::Length));
        assert_eq!(Quantity::of("S"), None);
    }

    #[test]
    fn header_errors() {
        assert_eq!(
            error("time,T1\n0,1\n"),
            "run.csv:1: no t_s column in the header"
        );
        assert_eq!(
            error("t_s;T1\n0;1\n"),
            "run.csv:1: no t_s column in the header (it has no comma but semicolons: \
             run files are comma-separated)"
        );
        assert_eq!(
            error("t_s\tT1\n0\t1\n"),
            "run.csv:1: no t_s column in the header (it has no comma but tabs: run \
             files are comma-separated)"
        );
        assert_eq!(
            error("t_s,T1,T2,T1\n0,1,2,3\n"),
            r#"run.csv:1: duplicate column name "T1" (columns 2 and 4)"#
        );
        // Names are compared after trimming.
        assert_eq!(
            error("t_s, T1 ,T1\n0,1,2\n"),
            r#"run.csv:1: duplicate column name "T1" (columns 2 and 3)"#
        );
        assert_eq!(
            error("t_s,T1,,T2\n0,1,2,3\n"),
            "run.csv:1: column 3 has an empty name"
        );
        assert_eq!(
            error("t_s,T1,\n0,1,\n"),
            "run.csv:1: column 3 has an empty name"
        );
        let utf16 = RunFile::from_reader("run.csv", &b"\xFF\xFEt\x00_\x00s\x00\n"[..], &STRICT);
        assert_eq!(
            utf16.unwrap_err().to_string(),
            "run.csv:1: name of column 1 is not UTF-8 text (save the file as UTF-8)"
        );
        assert_eq!(error(""), "run.csv: empty file (no header row)");
    }

    #[test]
    fn header_errors_are_fatal_even_when_skipping() {
        let err = read_str("t_s,T1,T1\n0,1,2\n", &SKIP).unwrap_err();
        assert!(matches!(err, RunFileError::DuplicateColumn { .. }));
        let err = read_str("T1\n1\n", &SKIP).unwrap_err();
        assert!(matches!(err, RunFileError::NoTimeColumn { .. }));
    }

    #[test]
    fn time_must_increase() {
        assert_eq!(
            error("t_s,T1\n1815,1\n1800,2\n"),
            "run.csv:3:1 (t_s): time 1800 is not after the previous row's time 1815"
        );
        assert_eq!(
            error("t_s,T1\n0.5,1\n0.5,2\n"),
            "run.csv:3:1 (t_s): time 0.5 is not after the previous row's time 0.5"
        );
        assert_eq!(
            error("t_s,T1\n1e14,1\n-1e14,2\n"),
            "run.csv:3:1 (t_s): time -100000000000000 is not after the previous row's time 100000000000000"
        );
    }

    #[test]
    fn missing_time_message() {
        assert_eq!(
            error("t_s,T1\n0,1\n,2\n"),
            "run.csv:3:1 (t_s): missing time"
        );
        assert_eq!(
            error("t_s,T1\n0,1\n  ,2\n"),
            "run.csv:3:1 (t_s): missing time"
        );
    }

    #[test]
    fn field_count_messages() {
        assert_eq!(
            error("t_s,T1,T2\n0,1,2\n15,1\n"),
            "run.csv:3: expected 3 fields, found 2"
        );
        assert_eq!(
            error("t_s,T1,T2\n0,1,2,\n"),
            "run.csv:2: expected 3 fields, found 4"
        );
    }

    #[test]
    fn header_only_has_no_data_rows() {
        assert_eq!(error("t_s,T1\n"), "run.csv: no data rows");
        assert_eq!(error("t_s,T1"), "run.csv: no data rows");
    }

    #[test]
    fn all_rows_bad_when_skipping_is_an_error_that_says_so() {
        let err = read_str("t_s,T1\n0,x\n,1\n", &SKIP).unwrap_err();
        assert_eq!(
            err.to_string(),
            "run.csv: no valid data rows (all 2 skipped; first: \
             run.csv:2:2 (T1): cannot parse \"x\" as a number)"
        );
    }

    #[test]
    fn skip_bad_rows_records_every_skipped_row_with_the_strict_message() {
        let csv = "t_s,T1,T2\n\
                   0,1,2\n\
                   15,abc,2\n\
                   30,inf,2\n\
                   45,1\n\
                   ,1,2\n\
                   0,1,2\n\
                   60,4,\n\
                   60,5,5\n\
                   75,6,6\n";
        let run = read_str(csv, &SKIP).unwrap();
        assert_eq!(run.t_s, [0.0, 60.0, 75.0]);
        assert_eq!(col(&run, "T1"), [Some(1.0), Some(4.0), Some(6.0)]);
        assert_eq!(col(&run, "T2"), [Some(2.0), None, Some(6.0)]);
        let lines: Vec<u64> = run.skipped.iter().map(|s| s.line).collect();
        assert_eq!(lines, [3, 4, 5, 6, 7, 9]);
        let reasons: Vec<String> = run.skipped.iter().map(ToString::to_string).collect();
        assert_eq!(
            reasons,
            [
                r#"run.csv:3:2 (T1): cannot parse "abc" as a number"#,
                r#"run.csv:4:2 (T1): value "inf" is not finite"#,
                "run.csv:5: expected 3 fields, found 2",
                "run.csv:6:1 (t_s): missing time",
                "run.csv:7:1 (t_s): time 0 is not after the previous row's time 0",
                "run.csv:9:1 (t_s): time 60 is not after the previous row's time 60",
            ]
        );
        // The strict reader stops at the first of them, with the same message.
        assert_eq!(error(csv), reasons[0]);
        for skipped in &run.skipped {
            assert_eq!(skipped.line, skipped.reason.line);
        }
    }

    #[test]
    fn bom_crlf_whitespace_and_quotes() {
        let csv = "\u{FEFF} t_s , \"T1\" ,T2\r\n 0 , \"1.5\" ,\r\n15,\" 2 \",3\r\n";
        let run = read_str(csv, &STRICT).unwrap();
        assert_eq!(run.columns, ["T1", "T2"]);
        assert_eq!(run.t_s, [0.0, 15.0]);
        assert_eq!(col(&run, "T1"), [Some(1.5), Some(2.0)]);
        assert_eq!(col(&run, "T2"), [None, Some(3.0)]);
        assert_eq!(
            error("\u{FEFF}t_s,T1\r\n0,1\r\n15,x\r\n"),
            r#"run.csv:3:2 (T1): cannot parse "x" as a number"#
        );
    }

    #[test]
    fn line_numbers_count_multiline_quoted_fields_and_blank_lines() {
        // The quoted header name spans lines 1-2; its newline is trimmed away
        // only at the ends, so it stays part of the name.
        let csv = "t_s,\"T1\nlong\"\n0,1\n\n15,x\n";
        assert_eq!(
            error(csv),
            "run.csv:5:2 (\"T1\\nlong\"): cannot parse \"x\" as a number"
        );
        let csv = "t_s,T1\n0,\"1\n\"\n15,bad\n";
        assert_eq!(
            error(csv),
            r#"run.csv:4:2 (T1): cannot parse "bad" as a number"#
        );
    }

    #[test]
    fn line_numbers_with_crlf_and_blank_lines() {
        // csv's own positions are one line short after each CRLF and each
        // skipped blank line; these are the cases that would show it.
        assert_eq!(
            error("t_s,T1\r\n0,1\r\n\r\n\r\n15,1\r\n30,x\r\n"),
            r#"run.csv:6:2 (T1): cannot parse "x" as a number"#
        );
        assert_eq!(
            error("\n\r\nt_s,T1,T1\n0,1,2\n"),
            r#"run.csv:3: duplicate column name "T1" (columns 2 and 3)"#
        );
    }

    /// Issue 14: a file with CR-only line ends (old Mac, some loggers) named
    /// every bad cell as line 1.
    #[test]
    fn line_numbers_with_cr_only_line_ends() {
        assert_eq!(
            error("t_s,T1\r0,1\r15,1\r30,x\r"),
            r#"run.csv:4:2 (T1): cannot parse "x" as a number"#
        );
        // Mixed: CR, CRLF, LF and a CR-only blank line.
        assert_eq!(
            error("t_s,T1\r0,1\r\n15,1\n\r30,x\n"),
            r#"run.csv:5:2 (T1): cannot parse "x" as a number"#
        );
    }

    /// A reader that hands out one byte per call, so every line start falls
    /// on a read boundary.
    struct Trickle<'a>(&'a [u8]);

    impl io::Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            match (self.0.split_first(), buf.first_mut()) {
                (Some((&byte, rest)), Some(slot)) => {
                    *slot = byte;
                    self.0 = rest;
                    Ok(1)
                }
                _ => Ok(0),
            }
        }
    }

    #[test]
    fn line_numbers_do_not_depend_on_read_boundaries() {
        let csv = b"\xEF\xBB\xBFt_s,T1\r\n0,\"1\r\n\"\r\n\r\n15,1\r\n\n30,1\n45,y\n";
        let run = RunFile::from_reader("run.csv", Trickle(csv), &SKIP).unwrap();
        assert_eq!(run.t_s, [0.0, 15.0, 30.0]);
        assert_eq!(
            run.skipped
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>(),
            [r#"run.csv:8:2 (T1): cannot parse "y" as a number"#]
        );
    }

    #[test]
    fn line_index_memory_stays_bounded() {
        let csv: String = std::iter::once("t_s,a\n".to_owned())
            .chain((0..100_000).map(|i| format!("{i},1\n")))
            .collect();
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .from_reader(LineStarts::new(csv.as_bytes()));
        let mut record = csv::ByteRecord::new();
        let mut most = 0;
        while next_record(&mut rdr, &mut record, "run.csv").unwrap() {
            line_of(&mut rdr, &record);
            most = most.max(rdr.get_ref().starts.len());
        }
        assert!(most < 10_000, "{most} line starts held");
    }

    #[test]
    fn space_before_quotes_is_tolerated() {
        let run = read_str("t_s, \"T1\", \"a\"\"b\"\n0, \" 1.5 \" , \"\"\n", &STRICT).unwrap();
        assert_eq!(run.columns, ["T1", "a\"b"]);
        assert_eq!(col(&run, "T1"), [Some(1.5)]);
        assert_eq!(col(&run, "a\"b"), [None]);
        // Without leading space a quote inside a field is kept as text.
        assert_eq!(
            error("t_s,T1\n0,1\"\"\n"),
            r#"run.csv:2:2 (T1): cannot parse "1\"\"" as a number"#
        );
    }

    #[test]
    fn reads_from_a_file_on_disk() {
        let mut file = tempfile::NamedTempFile::new().unwrap();
        file.write_all(b"t_s,T1\n0,1\n1,2\n").unwrap();
        let run = RunFile::read(file.path(), &STRICT).unwrap();
        assert_eq!(run.path, file.path());
        assert_eq!(col(&run, "T1"), [Some(1.0), Some(2.0)]);
    }

    #[test]
    fn directory_is_an_io_error() {
        let dir = tempfile::tempdir().unwrap();
        let err = RunFile::read(dir.path(), &STRICT).unwrap_err();
        assert!(matches!(err, RunFileError::Io { .. }), "{err}");
        assert!(err.to_string().starts_with("cannot read "), "{err}");
    }

    #[test]
    fn sampling_uniform_irregular_and_degenerate() {
        let uniform = Sampling::of(&[0.0, 15.0, 30.0, 45.0]);
        assert_eq!(
            uniform,
            Sampling {
                n: 4,
                dt_median_s: Some(15.0),
                dt_min_s: Some(15.0),
                dt_max_s: Some(15.0),
                is_uniform: true,
            }
        );
        // Rounding of printed times is tolerated ...
        assert!(Sampling::of(&[0.0, 0.1, 0.2, 0.30000001, 0.4]).is_uniform);
        assert!(Sampling::of(&[1e9, 1e9 + 0.1, 1e9 + 0.2]).is_uniform);
        // ... a real gap or jitter is not.
        let gap = Sampling::of(&[0.0, 15.0, 30.0, 60.0, 75.0]);
        assert!(!gap.is_uniform);
        assert_eq!(gap.dt_median_s, Some(15.0));
        assert_eq!(gap.dt_min_s, Some(15.0));
        assert_eq!(gap.dt_max_s, Some(30.0));
        assert!(!Sampling::of(&[0.0, 1.0, 2.001]).is_uniform);
        // Even number of steps: median is the mean of the middle two.
        assert_eq!(Sampling::of(&[0.0, 1.0, 4.0]).dt_median_s, Some(2.0));
        for t in [&[][..], &[5.0][..]] {
            let s = Sampling::of(t);
            assert_eq!(s.n, t.len());
            assert_eq!((s.dt_median_s, s.dt_min_s, s.dt_max_s), (None, None, None));
            assert!(!s.is_uniform);
        }
        let run = read_str("t_s,a\n0,1\n1,1\n3,1\n", &STRICT).unwrap();
        assert!(!run.sampling().is_uniform);
        assert_eq!(run.sampling().n, 3);
    }

    #[test]
    fn resample_exact_points_and_midpoints() {
        let t = [0.0, 10.0, 20.0];
        let x = [Some(1.0), Some(3.0), Some(-1.0)];
        assert_eq!(
            resample_linear(&t, x, &[0.0, 5.0, 10.0, 12.5, 20.0]),
            [Some(1.0), Some(2.0), Some(3.0), Some(2.0), Some(-1.0)]
        );
        // Several grid points between two samples, and grid == t.
        assert_eq!(resample_linear(&t, x, &[2.5, 7.5]), [Some(1.5), Some(2.5)]);
        assert_eq!(resample_linear(&t, x, &t), x);
    }

    #[test]
    fn resample_bridges_gaps_and_never_extrapolates() {
        let t = [0.0, 10.0, 20.0, 30.0, 40.0];
        let x = [None, Some(0.0), None, Some(10.0), None];
        assert_eq!(
            resample_linear(
                &t,
                x,
                &[-5.0, 0.0, 5.0, 10.0, 15.0, 20.0, 30.0, 35.0, 40.0, 50.0]
            ),
            [
                None,
                None,
                None,
                Some(0.0),
                Some(2.5),
                Some(5.0),
                Some(10.0),
                None,
                None,
                None
            ]
        );
        // A single valid sample is only known at its own time.
        assert_eq!(
            resample_linear(&[0.0, 1.0], [None, Some(4.0)], &[0.5, 1.0, 1.5]),
            [None, Some(4.0), None]
        );
        // Non-finite values count as gaps.
        assert_eq!(
            resample_linear(&t[..3], [Some(0.0), Some(f64::NAN), Some(2.0)], &[10.0]),
            [Some(1.0)]
        );
    }

    #[test]
    fn resample_degenerate_inputs_do_not_panic() {
        let t = [0.0, 1.0, 2.0];
        let x = [Some(0.0), Some(1.0), Some(2.0)];
        assert!(resample_linear(&t, x, &[]).is_empty());
        assert_eq!(resample_linear(&[], [], &[0.0]), [None]);
        assert_eq!(
            resample_linear(&t, x[..2].iter().copied(), &[0.5, 1.5]),
            [Some(0.5), None]
        );
        assert_eq!(resample_linear(&t[..2], x, &[0.5, 1.5]), [Some(0.5), None]);
        assert_eq!(
            resample_linear(&t, x, &[f64::NAN, 0.5, f64::INFINITY, 1.5]),
            [None, Some(0.5), None, Some(1.5)]
        );
        // A grid going back in time gives None rather than extrapolating.
        assert_eq!(resample_linear(&t, x, &[1.5, 0.5]), [Some(1.5), None]);
        // Huge values of opposite sign do not overflow.
        let big = resample_linear(&[0.0, 1.0], [Some(-f64::MAX), Some(f64::MAX)], &[0.5]);
        assert_eq!(big, [Some(0.0)]);
    }

    /// A grid of more than 100 points per row (and over 100,000) is
    /// refused, naming a gap when one is to blame and the step otherwise.
    #[test]
    fn a_grid_mostly_interpolated_is_refused() {
        let mut t: Vec<f64> = (0..721).map(|k| f64::from(k) * 10.0).collect();
        let even = Sampling::of(&t);
        assert_eq!(even.check_grid(100_000, 0.072), Ok(()), "small grids pass");
        assert_eq!(even.check_grid(72_100, 0.1), Ok(()), "100 per row pass");
        let fine = even.check_grid(7_200_001, 0.001).unwrap_err().to_string();
        assert_eq!(
            fine,
            "721 rows resampled every 0.001 s would make 7200001 points, more than 100 \
             per row: a model step of 0.001 s is too fine for rows 10 s apart"
        );
        for v in &mut t[300..] {
            *v += 9.9e7;
        }
        let gap = Sampling::of(&t).check_grid(9_900_721, 10.0).unwrap_err();
        assert_eq!(
            gap.to_string(),
            "721 rows resampled every 10 s would make 9900721 points, more than 100 per \
             row: the longest step between rows is 99000010 s (the median 10 s); a run \
             with a gap that long is two runs: split the file there"
        );
    }

    #[test]
    fn uniform_grid_basics() {
        assert_eq!(
            uniform_grid(0.0, 60.0, 15.0).unwrap(),
            [0.0, 15.0, 30.0, 45.0, 60.0]
        );
        assert_eq!(
            uniform_grid(0.0, 59.0, 15.0).unwrap(),
            [0.0, 15.0, 30.0, 45.0]
        );
        assert_eq!(uniform_grid(-1.0, 1.0, 1.0).unwrap(), [-1.0, 0.0, 1.0]);
        assert_eq!(uniform_grid(5.0, 5.0, 1.0).unwrap(), [5.0]);
        assert_eq!(uniform_grid(5.0, 5.5, 1.0).unwrap(), [5.0]);
        // 0.3 / 0.1 is 2.9999999999999996 in floating point: still 4 points,
        // the last exactly at the end.
        assert_eq!(uniform_grid(0.0, 0.3, 0.1).unwrap(), [0.0, 0.1, 0.2, 0.3]);
        let grid = uniform_grid(0.0, 166_710.0, 15.0).unwrap();
        assert_eq!(grid.len(), 11_115);
        assert_eq!(grid.last(), Some(&166_710.0));
        let grid = uniform_grid(1.7e9, 1.7e9 + 100.0, 1e-3).unwrap();
        assert_eq!(grid.len(), 100_001);
        assert!(grid.iter().zip(&grid[1..]).all(|(a, b)| a < b));
        assert!(grid.iter().all(|&g| g <= 1.7e9 + 100.0));
    }

    #[test]
    fn uniform_grid_rejects_bad_arguments() {
        let msg = |r: Result<Vec<f64>, GridError>| r.unwrap_err().to_string();
        for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                uniform_grid(0.0, 1.0, dt),
                Err(GridError::BadStep { .. })
            ));
        }
        assert_eq!(
            msg(uniform_grid(0.0, 1.0, -1.0)),
            "time grid step must be a positive finite number of seconds, got -1"
        );
        assert_eq!(
            msg(uniform_grid(f64::NAN, 1.0, 1.0)),
            "time grid bounds must be finite, got NaN s to 1 s"
        );
        assert!(matches!(
            uniform_grid(0.0, f64::INFINITY, 1.0),
            Err(GridError::NotFinite { .. })
        ));
        assert_eq!(
            msg(uniform_grid(10.0, 5.0, 1.0)),
            "time grid end 5 s is before its start 10 s"
        );
        assert_eq!(
            msg(uniform_grid(0.0, 1e300, 1.0)),
            "time grid from 0 s to 1e300 s every 1 s would exceed 10000000 points"
        );
        assert!(matches!(
            uniform_grid(-f64::MAX, f64::MAX, 1e300),
            Err(GridError::TooManyPoints { .. })
        ));
        // The limit is checked at its edge without building an 80 MB grid.
        assert!(matches!(
            uniform_grid(0.0, MAX_GRID_POINTS as f64, 1.0),
            Err(GridError::TooManyPoints { .. })
        ));
        assert_eq!(
            msg(uniform_grid(1e16, 1e16 + 100.0, 1.0)),
            "time grid step 1 s is too small for times 1e16 s to 1.00000000000001e16 s"
        );
    }

    /// The real recording shipped with the project (`shared/` sits beside the
    /// repository, in development and in CI alike).
    #[test]
    fn sampling_tally_agrees_with_sampling_of() {
        let cases: [&[f64]; 6] = [
            &[],
            &[3.0],
            &[0.0, 1.0, 2.0, 3.0],
            &[0.0, 15.0, 45.0, 60.0, 75.0],
            &[0.0, 0.1, 0.2, 0.30000000000000004, 0.4, 0.5],
            &[1.0, 1.5, 3.5, 3.6, 10.0, 10.5],
        ];
        for t in cases {
            let mut tally = SamplingTally::default();
            t.iter().for_each(|&x| tally.push(x));
            assert_eq!(tally.sampling(), Sampling::of(t), "{t:?}");
        }
    }

    #[test]
    fn row_stream_gives_the_rows_and_errors_of_the_reader() {
        let csv = "t_s,a,b\n0,1,x\n1,,2\n1,3,4\n2,5,6\n";
        let opts = ReadOptions {
            skip_bad_rows: true,
            only: Some(vec!["a".into()]),
        };
        let mut s = RowStream::start("r.csv".into(), csv.as_bytes(), &opts).unwrap();
        let a = s.index_of("a").unwrap();
        assert_eq!(s.index_of("b"), None);
        let mut got = Vec::new();
        while let Some(item) = s.next_item().unwrap() {
            match item {
                StreamItem::Row(t) => got.push(format!("{t}:{:?}", s.row()[a])),
                StreamItem::Skipped(r) => got.push(format!("skip {} {}", r.before, r.reason)),
            }
        }
        assert_eq!(
            got,
            [
                "0:Some(1.0)",
                "1:None",
                "skip 2 r.csv:4:1 (t_s): time 1 is not after the previous row's time 1",
                "2:Some(5.0)"
            ]
        );
        let strict = ReadOptions::default();
        let mut s = RowStream::start("run.csv".into(), csv.as_bytes(), &strict).unwrap();
        let e = loop {
            match s.next_item() {
                Err(e) => break e.to_string(),
                Ok(None) => panic!("no error"),
                Ok(Some(_)) => {}
            }
        };
        assert_eq!(e, error(csv));
    }

    #[test]
    fn reads_the_real_fl_thermal_run() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/fl_thermal/run.csv");
        let run = RunFile::read(&path, &STRICT).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(run.len(), 11_115);
        assert_eq!(run.columns.len() + 1, 23);
        assert_eq!(run.columns.first().map(String::as_str), Some("speed_rpm"));
        assert!(run.has_column("T16") && run.has_column("ch5_um"));
        assert!(run.skipped.is_empty());
        let s = run.sampling();
        assert!(s.is_uniform);
        assert_eq!(s.n, 11_115);
        assert_eq!(
            (s.dt_median_s, s.dt_min_s, s.dt_max_s),
            (Some(15.0), Some(15.0), Some(15.0))
        );
        assert_eq!(run.column("T1").and_then(|c| c.get(0)), Some(26.1909));
        assert_eq!(run.t_s.first(), Some(&0.0));
        for (name, values) in run.iter_columns() {
            assert_eq!(values.len(), run.len(), "{name}");
        }
    }

    #[test]
    fn unread_columns_are_kept_by_name_and_never_parsed() {
        let opts = ReadOptions {
            only: Some(vec!["T1".into()]),
            ..STRICT
        };
        let run = RunFile::from_reader(
            "run.csv",
            "t_s,T1,program,T2\n0,20,O1234 roughing,x\n1,21,,inf\n".as_bytes(),
            &opts,
        )
        .unwrap();
        assert_eq!(run.columns, ["T1", "program", "T2"]);
        assert_eq!(
            run.column("T1").map(Cells::to_options),
            Some(vec![Some(20.0), Some(21.0)])
        );
        assert_eq!(run.column("program"), None);
        assert!(run.has_column("T2"));
        assert_eq!(run.iter_columns().count(), 1);
        // The columns asked for are still strict.
        let e = RunFile::from_reader("run.csv", "t_s,T1\n0,abc\n".as_bytes(), &opts).unwrap_err();
        assert_eq!(
            e.to_string(),
            "run.csv:2:2 (T1): cannot parse \"abc\" as a number"
        );
    }
}
