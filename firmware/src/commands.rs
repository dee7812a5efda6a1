//! The serial command channel's effect on the hub: what the board's
//! lowest-priority task does with each decoded [`Command`], kept here so it
//! is tested on the host (the RTIC task only locks, feeds and logs).
//!
//! - `Ping` answers `Pong` with the protocol version.
//! - `SetToolLength` sets the pipeline's tool length (refused out of range):
//!   the same latch the CNC's TOOL_POSITION frame sets (`cnc_inputs`).
//! - Upload commands go to the [`Uploader`]; the pipeline shows
//!   `UPLOADING` while one is in progress (set *before* the erase, which
//!   stalls the CPU, so the CNC sees why frames pause), the watchdog is fed
//!   right before that erase, and a committed model is swapped in under one
//!   lock between two samples.

use crate::hub::Hub;
use crate::pipeline::{Pipeline, SwapError};
use crate::protocol::{Command, CommandKind, ErrorCode, HubMessage, PROTOCOL_VERSION};
use crate::upload::{Committed, MappedFlash, Slot, Uploader};

/// Access to the pipeline the sampling task shares: on the board an RTIC
/// lock, on the host the pipeline itself.
pub trait SharedPipeline {
    /// Runs `f` with the pipeline (under the lock on the board).
    fn with<R>(&mut self, f: impl FnOnce(&mut Pipeline) -> R) -> R;
}

impl SharedPipeline for Pipeline {
    fn with<R>(&mut self, f: impl FnOnce(&mut Pipeline) -> R) -> R {
        f(self)
    }
}

/// What a command did besides its reply, for the board's log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// Nothing to log.
    None,
    /// An upload of this many bytes began: the slot was erased.
    Erased {
        /// Announced blob length.
        len: u32,
    },
    /// A new model was committed to `slot` and now runs.
    Swapped {
        /// Where it is stored.
        slot: Slot,
    },
    /// A model was committed to `slot` but the pipeline refused it (cannot
    /// happen for a model the uploader validated; logged if it does).
    SwapRefused {
        /// Where it is stored.
        slot: Slot,
        /// Why.
        error: SwapError,
    },
}

/// Carries out `cmd`; returns the reply to send and what to log.
/// `before_erase` runs right before an upload's erase (feed the watchdog).
pub fn execute<F: MappedFlash>(
    pipeline: &mut impl SharedPipeline,
    uploader: &mut Uploader<F>,
    before_erase: impl FnOnce(),
    cmd: &Command,
) -> (HubMessage, Event) {
    match cmd {
        Command::Ping => (
            HubMessage::Pong {
                protocol: PROTOCOL_VERSION,
            },
            Event::None,
        ),
        Command::SetToolLength { mm } => {
            let reply = match pipeline.with(|p| p.set_tool_length_mm(f64::from(*mm))) {
                Ok(()) => HubMessage::Ack(CommandKind::SetToolLength),
                Err(_) => HubMessage::Nack {
                    command: CommandKind::SetToolLength,
                    error: ErrorCode::OutOfRange,
                },
            };
            (reply, Event::None)
        }
        _ => upload(pipeline, uploader, before_erase, cmd),
    }
}

/// The upload commands (see the module docs).
fn upload<F: MappedFlash>(
    pipeline: &mut impl SharedPipeline,
    uploader: &mut Uploader<F>,
    before_erase: impl FnOnce(),
    cmd: &Command,
) -> (HubMessage, Event) {
    let begin = match cmd {
        Command::UploadBegin { len, .. } => {
            pipeline.with(|p| p.set_uploading(true));
            before_erase();
            Some(*len)
        }
        _ => None,
    };
    // A commit decodes the blob into this hub as its check (outside the
    // pipeline's lock: decoding takes milliseconds, a TF bank up to a
    // second), and the hub is swapped in once the slot is committed (under
    // the lock: an exchange, no hub by value; docs/firmware-cost.md,
    // "Stack"). The other commands leave it empty.
    let mut hub = Hub::empty();
    let load = |head: &[u8], tail: &[u8]| hub.reload_split(head, tail);
    let Some((reply, committed)) = uploader.handle_with(cmd, load) else {
        // Not an upload command: `execute` answers every other kind.
        return (
            HubMessage::Nack {
                command: cmd.kind(),
                error: ErrorCode::Unsupported,
            },
            Event::None,
        );
    };
    let uploading = uploader.is_uploading();
    pipeline.with(|p| p.set_uploading(uploading));
    let event = match (committed, begin, &reply) {
        (Some(Committed { slot, .. }), _, _) => match pipeline.with(|p| p.swap_model(&mut hub)) {
            Ok(()) => Event::Swapped { slot },
            Err(error) => Event::SwapRefused { slot, error },
        },
        (None, Some(len), HubMessage::Ack(_)) => Event::Erased { len },
        _ => Event::None,
    };
    (reply, event)
}

#[cfg(test)]
mod tests;
