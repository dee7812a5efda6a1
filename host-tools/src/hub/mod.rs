//! `thermcomp hub ...`: the host side of the sensor hub's serial link
//! (`firmware::protocol`; spec and sequence: `docs/wire-format.md`,
//! "Serial link", "Model upload" and "Uploading a model over serial").
//!
//! Three layers: [`link::Link`] is a byte pipe with a read timeout
//! ([`serial::SerialLink`] on the bench); [`session::Session`] speaks the
//! protocol over any link (and is tested against scripted hubs);
//! `cli/hub.rs` parses the command line, checks inputs and prints.

pub mod link;
pub mod monitor;
pub mod serial;
pub mod session;
