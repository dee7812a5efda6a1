//! Hardware-independent part of the sensor-hub firmware: board facts, the
//! memory map and the model hub (sample in, offsets out).
//!
//! `no_std` and free of HAL types, so the same code builds for the board
//! (linked into the RTIC application in `main.rs`) and for the host, where
//! `cargo test -p firmware` runs its unit tests.
//!
//! * [`board`]: clocks, pinout, bus speeds, task periods.
//! * [`layout`]: the flash/RAM map of `memory.x`, including the model slots.
//! * [`offsets`]: what the hub reports per sample.
//! * [`hub`]: loads the model blob from a slot and turns each sample into
//!   axis offsets, holding the last good offsets when a sample is bad. With
//!   the `model` feature off (`--no-default-features`) it is a stand-in that
//!   always gives zero offsets and does not link model-core: the baseline
//!   for measuring what the model path costs in flash and RAM.
#![cfg_attr(not(test), no_std)]

pub mod board;
pub mod layout;
pub mod offsets;

#[cfg(feature = "model")]
pub mod hub;

#[cfg(not(feature = "model"))]
#[path = "hub_shell.rs"]
pub mod hub;
