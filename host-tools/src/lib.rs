//! `thermcomp`'s library: the spec reader, run-file reader, runner and
//! subcommands, kept apart from `main` so tests can call them directly.

pub mod bench;
pub mod blobfile;
pub mod dataset;
pub mod demo;
pub mod diagnose;
pub mod distributions;
pub mod eval;
pub mod fit;
pub mod fsio;
pub mod hub;
pub mod predict;
pub mod refit;
pub mod replay;
pub mod rng;
pub mod runfile;
pub mod runner;
pub mod score;
pub mod select;
pub mod show;
pub mod simulate;
pub mod source;
pub mod spec;
pub mod twin;
