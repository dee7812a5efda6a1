//! The thermal twin: a lumped-parameter model of a motorized spindle on a
//! machining centre that turns a speed profile into a run file (CONTRACT.md
//! section 2) with temperatures, five-point probe readings and tool-tip
//! displacements, with the unmodelled effects of section 3 switchable.
//!
//! One concept per module: [`machine`] (the machine file), [`network`] (the
//! heat equations), [`integrate`] (exact zero-order-hold discretisation),
//! [`expansion`] (temperatures to displacement), [`sensors`], [`profile`]
//! (speed over time), [`effects`], [`rng`] (seeded noise) and [`sim`] (one
//! run), [`calibrate`] (grey-box fit of a machine to a measured run) with
//! its optimiser [`lm`], its simulation [`drive`] (which an effect can
//! drive) and the fitted parameters' description [`param`]. Method and numbers: docs/twin.md.

pub mod calibrate;
pub mod drive;
pub mod effects;
pub mod expansion;
pub mod integrate;
pub mod lm;
pub mod machine;
pub mod network;
pub mod param;
pub mod profile;
pub mod rng;
pub mod sensors;
pub mod sim;
