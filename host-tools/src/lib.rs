//! `thermcomp`'s library: the spec reader, run-file reader, runner and
//! subcommands, kept apart from `main` so tests can call them directly.
//! The command line ([`cli`]: clap, text tables, printing) is the default
//! feature `cli`; without it the typed jobs alone build, without clap.

/// `eprintln!` that never panics: std's panics when stderr is closed (as in
/// `thermcomp ... 2>&1 | head`), which would abort a command mid-work for
/// a note nobody can read any more. Defined before the modules, so it
/// shadows std's in all of them.
macro_rules! eprintln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// `eprint!` that never panics (see `eprintln!` above).
macro_rules! eprint {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stderr(), $($arg)*);
    }};
}

pub mod bench;
#[cfg(feature = "cli")]
pub mod cli;
pub mod data;
pub mod demo;
pub mod diagnose;
pub mod eval;
pub mod fit;
pub mod fivepoint;
pub mod fivepoint_demo;
pub mod hub;
pub mod num;
pub mod plot;
pub mod predict;
pub mod refit;
pub mod replay;
pub mod runner;
pub mod score;
pub mod select;
pub mod show;
pub mod simulate;
pub mod stream;
pub mod twin;
