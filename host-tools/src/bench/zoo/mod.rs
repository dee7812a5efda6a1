//! The plant zoo: real machines the diagnosis was not built around.
//!
//! An independent lumped thermal simulator (no code of [`crate::twin`]):
//! its own networks ([`network`]), integrator ([`integrate`], RK4), heat
//! laws ([`laws`]), sensors ([`sensors`]), boundaries ([`boundary`]: the
//! room air, a chiller whose period drifts with load) and speed profiles
//! ([`inputs`]); ten structurally different plants ([`catalogue`], one
//! held out of development); the effects of CONTRACT.md section 3 as these
//! plants have them ([`effects`]); a per-case parameter mismatch
//! ([`mismatch`]); the case grid and the two run files per case
//! ([`cases`]); running and scoring ([`bench`]) and the reports
//! ([`report`]). docs/gap-benchmark.md, "Plant zoo", describes it.

pub mod bench;
pub mod boundary;
pub mod cases;
pub mod catalogue;
pub mod effects;
pub mod inputs;
pub mod integrate;
pub mod laws;
pub mod mismatch;
pub mod network;
pub mod noise;
pub mod plant;
pub mod report;
pub mod sensors;
pub mod simulate;
pub mod table;

pub use cases::{ZooCase, ZooParams, ZooPlan};
