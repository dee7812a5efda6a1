//! `thermcomp bench`: benchmarks of the tool's own methods with known
//! answers.
//!
//! - [`gap`]: the blind benchmark of `thermcomp diagnose`
//!   (docs/gap-benchmark.md): by default on the plant zoo ([`zoo`]:
//!   independently built plants, one held out), with `--twin` on
//!   twin-derived cases ([`cases`]). Both share [`outcome`] (what a
//!   diagnosis said, running cases in parallel), [`summary`] (confusion
//!   matrix and rates) and [`report`] (tables and SVG).
//!
//! The flags and the printing are `cli::bench`'s.

pub mod cases;
pub mod gap;
pub mod outcome;
pub mod report;
pub mod summary;
pub mod zoo;
