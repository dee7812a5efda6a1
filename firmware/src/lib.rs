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
//! * [`report`]: what the pipeline hands to the emitters after each sample.
//! * [`pipeline`]: readings -> validate -> spike filter -> model -> fault
//!   supervisor -> slew limit/clamp -> [`report::Report`], once per sample,
//!   infallible after one `validate` (feature `model`).
//! * `rtd` (feature `model`): one MAX31865 converter channel: driver
//!   errors to channel faults, fault clearing, retry while down.
//! * [`spike`]: rejects single-sample jumps no thermal signal can make.
//! * [`supervisor`]: hold, then ramp offsets to zero while inputs are bad.
//! * [`limiter`]: per-output clamp and slew limit, the last stop before the CNC.
//! * [`config`]: the shared settings error and duration-to-samples rounding.
//! * [`hub`]: loads the model blob from a slot and turns each sample into
//!   axis offsets, holding the last good offsets when a sample is bad. With
//!   the `model` feature off (`--no-default-features`) it is a stand-in that
//!   always gives zero offsets and does not link model-core: the baseline
//!   for measuring what the model path costs in flash and RAM.
//! * [`can_frames`]: the CAN frames the CNC reads (spec: `docs/wire-format.md`,
//!   `thermcomp.dbc`).
//! * [`can_rx`]: the CAN frames the hub receives from the CNC (spindle
//!   speed and power, tool length, axis position).
//! * [`canopen`]: the hub as a CANopen device (CiA 301): object dictionary,
//!   SDO server, NMT, heartbeat, PDOs (the frames above), EMCY, settings.
//! * `cnc_inputs` (feature `model`): which model input each received value
//!   feeds, its timeout, the tool length's latch.
//! * [`protocol`]: the serial link's COBS/postcard messages.
//! * `upload` (feature `model`): model upload into the inactive A/B slot.
//! * `commands` (feature `model`): what each serial command does to the hub.
//! * `tip` (feature `model`): a five-point model's outputs turned into
//!   tool-tip offsets with the current tool length.
//! * `ram_flash` (tests and feature `test-support`): NOR flash in RAM.
#![cfg_attr(not(test), no_std)]

pub mod board;
#[cfg(feature = "model")]
pub mod boot;
pub mod can_frames;
pub mod can_rx;
pub mod canopen;
pub mod layout;
pub mod offsets;
pub mod protocol;
pub mod report;

#[cfg(all(test, feature = "model"))]
mod test_util;
#[cfg(feature = "model")]
pub mod upload;

#[cfg(feature = "model")]
pub mod commands;

#[cfg(all(feature = "model", any(test, feature = "ram-flash")))]
pub mod ram_flash;

pub mod config;
pub mod limiter;
pub mod plausible;
pub mod spike;
pub mod supervisor;

#[cfg(feature = "model")]
pub mod pipeline;

#[cfg(feature = "model")]
pub mod rtd;

#[cfg(feature = "model")]
pub mod tip;

#[cfg(feature = "model")]
pub mod cnc_inputs;

#[cfg(feature = "model")]
pub mod hub;

#[cfg(not(feature = "model"))]
#[path = "hub_shell.rs"]
pub mod hub;
