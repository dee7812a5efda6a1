//! Thermal-error compensation models that run on the sensor hub.
//!
//! `no_std`, no allocation, no panics on any input: the same code runs in
//! the firmware on a Cortex-M4F and in `thermcomp` on the host, so what a
//! user validates on a PC is what the hub computes.
//!
//! - [`model`]: a model's inputs, outputs and kind; validation; stepping.
//! - [`blob`]: the versioned, CRC-checked postcard format that is flashed;
//!   [`slot`]: a blob loaded where the model lies (the hub's model static).
//! - model kinds: [`tf`] (seed 004), [`fbank`] (seed 004, fixed real poles),
//!   [`linear`] (seed 002), [`pcr`] and
//!   [`position`] (seed 003), [`bp`] (seeds 000/003), [`arma`] (seed 001).
//! - [`rtd`]: PT100/PT1000 conversion; [`geometry`]: five-point spindle
//!   measurement and 3-axis offsets; [`fivepoint`]: models of E and the
//!   tilts turned into tool-tip offsets; [`metrics`]: fit %, dpk, reduction...
#![no_std]
#![warn(missing_docs)]

#[cfg(feature = "alloc")]
extern crate alloc;

pub mod arma;
pub mod blob;
pub mod bp;
pub mod capacity;
pub mod error;
pub mod fbank;
pub mod fivepoint;
pub mod geometry;
mod in_place;
pub mod linear;
pub mod metrics;
pub mod model;
pub mod pcr;
pub mod poly;
pub mod position;
pub mod rtd;
pub mod slot;
pub mod tf;
mod wire;

pub use blob::{decode, encode, BlobError};
pub use model::{
    Bounds, Channel, Model, ModelError, ModelKind, ModelState, Name, Params, Reference, Span,
    ValidModel,
};
pub use slot::ModelSlot;
