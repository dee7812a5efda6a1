//! `thermcomp`'s library: the spec reader, run-file reader, runner and
//! subcommands, kept apart from `main` so tests can call them directly.
//! The command line ([`cli`]: clap, text tables, printing) is the default
//! feature `cli`; without it the typed jobs alone build, without clap.

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
