//! The hub as a CANopen device (CiA 301 v4.2; EDS per CiA 306:
//! `firmware/thermcomp.eds`), one module per concept:
//!
//! * [`od`]: the object dictionary, a static table of typed entries.
//! * [`abort`]: the SDO abort codes, shared by the dictionary and the server.
//! * [`sdo`]: the SDO server, expedited and segmented.
//! * [`nmt`]: NMT states and commands, the heartbeat producer.
//! * [`pdo`]: TPDOs and RPDOs from and into mapped objects; the default
//!   mapping keeps the frames of `docs/wire-format.md` byte for byte.
//! * [`emcy`]: emergency messages on sensor, input and model faults.
//! * [`settings`]: what a PLC may configure, and how it reaches the pipeline.
//! * `store` (feature `model`): the settings in flash (object 0x1010).
//! * [`node`]: all of it as one node: frames in, frames out.
//!
//! # Why our own stack
//!
//! `canopen-rs` 0.6.1 (crates.io, no_std) was read first. It was not used
//! because: its dictionary is a run-time `heapless::LinearMap` of tagged
//! values, every entry carrying a 32-byte string buffer (about 45 bytes per
//! entry, ~5 KiB of RAM for this dictionary against 16 KiB aimed for the
//! whole firmware), where a static table costs 4 bytes of RAM per entry;
//! a write is applied first and reported afterwards (`take_written_object`),
//! so a range check cannot refuse it with the abort code CiA 301 asks for
//! (0x0609_0030/31/32) before the value is in place; it depends on heapless
//! 0.8 while the firmware uses 0.9 (two copies linked); and it brings LSS,
//! SYNC, TIME and block transfer, which the hub does not need. The subset
//! here (one SDO server, static PDO mapping, NMT slave, heartbeat producer,
//! EMCY producer) is small, and every byte of it is tested.
//!
//! # What is not here
//!
//! SDO block transfer (answered with abort 0x0504_0001), node guarding,
//! SYNC-triggered PDOs, dynamic PDO mapping (the mapping objects are
//! read-only: CiA 301 allows a fixed mapping), an SDO server timeout (a
//! client that stops mid-transfer leaves it open until its next request,
//! which starts over), the EMCY inhibit time (0x1015) and the error history
//! (0x1003).

pub mod abort;
pub mod emcy;
pub mod nmt;
pub mod node;
pub mod od;
pub mod pdo;
pub mod sdo;
pub mod settings;
#[cfg(feature = "model")]
pub mod store;

pub use node::{Event, Node, Reaction};
pub use settings::Settings;

#[cfg(test)]
mod eds_tests;
