//! The serial link (USART2 on the ST-LINK virtual COM port, 115200 8N1):
//! postcard messages, each COBS-encoded and ended by one 0x00 byte.
//!
//! COBS removes every 0x00 from the encoded message, so 0x00 only ever marks
//! a frame's end: a receiver that starts mid-stream, or loses bytes, drops
//! one frame and is back in step at the next 0x00 with no timeouts. postcard
//! is the same encoding the model blob's body uses, so one serializer serves
//! both. Spec (with exact bytes): `docs/wire-format.md`.
//!
//! Host -> hub: [`Command`]. Hub -> host: [`HubMessage`] (telemetry after
//! every sample, an [`HubMessage::Ack`]/[`HubMessage::Nack`] for every
//! command, [`HubMessage::Pong`] for [`Command::Ping`]). Variant order is
//! the wire format (postcard writes the variant index): append, never
//! reorder, and bump [`PROTOCOL_VERSION`] on any change.
//!
//! [`FrameReader`] turns UART bytes, split however they arrive, into decoded
//! messages; garbage, overlong frames and bytes that do not decode give an
//! error for that frame and never a panic.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::offsets::{MAX_INPUTS, MAX_OUTPUTS};
use crate::report::Report;

/// Protocol version, answered by [`HubMessage::Pong`].
pub const PROTOCOL_VERSION: u16 = 1;

/// Most model bytes in one [`Command::UploadChunk`]: 64 bytes take 6 ms at
/// 115200 baud, so a 16 KiB blob is 256 chunks, each acknowledged; a lost
/// chunk costs one retry of 64 bytes. A multiple of every flash write size
/// up to 64 bytes (F446: 1 byte), which the upload relies on.
pub const CHUNK_MAX: usize = 64;

/// A command from the host.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Is the hub there? Answered with [`HubMessage::Pong`].
    Ping,
    /// Start a model upload: `len` bytes of blob, whose zlib CRC-32 (of the
    /// whole blob file) is `crc32`. Erases the inactive slot (1-2 s stall).
    /// Aborts any upload in progress.
    UploadBegin {
        /// Blob length in bytes.
        len: u32,
        /// CRC-32/ISO-HDLC of the whole blob.
        crc32: u32,
    },
    /// Blob bytes at `offset`; chunks must come in order, without gaps or
    /// overlap (offset = sum of earlier chunk lengths).
    UploadChunk {
        /// Offset of `bytes[0]` in the blob.
        offset: u32,
        /// 1 to [`CHUNK_MAX`] bytes.
        bytes: heapless::Vec<u8, CHUNK_MAX>,
    },
    /// All bytes sent: check the blob and, if good, make it the active model.
    UploadCommit,
    /// Drop the upload in progress; the running model is untouched.
    UploadAbort,
    /// The length of the tool now in the spindle, for models that use it.
    SetToolLength {
        /// Tool length in mm.
        mm: f32,
    },
}

/// Which command a reply answers (the [`Command`] variant without data).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CommandKind {
    /// [`Command::Ping`].
    Ping,
    /// [`Command::UploadBegin`].
    UploadBegin,
    /// [`Command::UploadChunk`].
    UploadChunk,
    /// [`Command::UploadCommit`].
    UploadCommit,
    /// [`Command::UploadAbort`].
    UploadAbort,
    /// [`Command::SetToolLength`].
    SetToolLength,
    /// A frame that did not decode as a command.
    Unknown,
}

impl Command {
    /// The command's kind, for the reply.
    pub const fn kind(&self) -> CommandKind {
        match self {
            Self::Ping => CommandKind::Ping,
            Self::UploadBegin { .. } => CommandKind::UploadBegin,
            Self::UploadChunk { .. } => CommandKind::UploadChunk,
            Self::UploadCommit => CommandKind::UploadCommit,
            Self::UploadAbort => CommandKind::UploadAbort,
            Self::SetToolLength { .. } => CommandKind::SetToolLength,
        }
    }
}

/// Why a command was refused (in [`HubMessage::Nack`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum ErrorCode {
    /// The frame did not decode (COBS, postcard, or too long).
    Malformed,
    /// This build cannot do that (e.g. uploads without the `model` feature).
    Unsupported,
    /// A chunk or commit with no upload in progress.
    NotUploading,
    /// The blob is longer than `max` bytes, or shorter than a blob can be.
    BadLength {
        /// Largest blob accepted.
        max: u32,
    },
    /// A chunk not at the next expected offset (out of order, repeated,
    /// overlapping or leaving a gap); resend from `expected`.
    OutOfOrder {
        /// The offset the hub expects next.
        expected: u32,
    },
    /// A chunk that is empty, runs past the announced length, or (except the
    /// last) is not a multiple of the flash write size.
    BadChunk,
    /// Commit before all bytes arrived.
    Incomplete {
        /// Bytes received so far.
        received: u32,
    },
    /// The bytes in flash do not have the CRC announced by `UploadBegin`.
    CrcMismatch,
    /// The blob does not decode (code: see `docs/wire-format.md`; 4 version,
    /// 6 CRC, 7 kind, 9 invalid model...). The running model is kept.
    BadBlob {
        /// Which check failed.
        reason: u8,
    },
    /// Erasing, writing or reading back the flash failed.
    Flash,
    /// A value outside its range (e.g. a negative or non-finite tool length).
    OutOfRange,
}

/// One sample's telemetry: the [`Report`] plus the raw temperatures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// Sample counter ([`Report::seq`]).
    pub seq: u32,
    /// Offsets sent to the CNC, um, model output order (f32: 0.06 nm
    /// resolution at 500 um, far below anything measurable).
    pub offsets_um: [f32; MAX_OUTPUTS],
    /// Model outputs in `offsets_um`.
    pub n_outputs: u8,
    /// `HubState::code`.
    pub state: u8,
    /// `StatusFlags` bits.
    pub flags: u16,
    /// Bit i: input i faulty.
    pub faulty_channels: u32,
    /// Raw readings in the model's input order, deg C (NaN: not read).
    pub temps_c: heapless::Vec<f32, MAX_INPUTS>,
}

impl Telemetry {
    /// From a report and the raw readings (readings past [`MAX_INPUTS`] are
    /// dropped).
    pub fn new(report: &Report, temps_c: &[f64]) -> Self {
        let mut temps = heapless::Vec::new();
        for t in temps_c.iter().take(MAX_INPUTS) {
            // Capacity is MAX_INPUTS, so this never fails.
            let _ = temps.push(*t as f32);
        }
        Self {
            seq: report.seq,
            offsets_um: report.offsets.map(|v| v as f32),
            n_outputs: report.n_outputs,
            state: report.state.code(),
            flags: report.flags.0,
            faulty_channels: report.faulty_channels,
            temps_c: temps,
        }
    }
}

/// A message from the hub.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum HubMessage {
    /// After every sample.
    Telemetry(Telemetry),
    /// The command was carried out.
    Ack(CommandKind),
    /// The command was refused; nothing changed unless the error says so.
    Nack {
        /// The refused command.
        command: CommandKind,
        /// Why.
        error: ErrorCode,
    },
    /// Answer to [`Command::Ping`].
    Pong {
        /// [`PROTOCOL_VERSION`].
        protocol: u16,
    },
}

/// Longest postcard encoding of a [`Command`]: `UploadChunk` with a 5-byte
/// varint offset, 1-byte length and [`CHUNK_MAX`] bytes, plus the variant.
pub const COMMAND_MAX_LEN: usize = 1 + 5 + 1 + CHUNK_MAX;
/// Longest postcard encoding of a [`HubMessage`]: `Telemetry` (variant 1,
/// seq 5, offsets 4x4, counts 2, flags 3, mask 5, length 1, temps 24x4).
pub const HUB_MESSAGE_MAX_LEN: usize = 1 + 5 + 4 * MAX_OUTPUTS + 2 + 3 + 5 + 1 + 4 * MAX_INPUTS;

/// Bytes on the wire for a message of at most `n` bytes: COBS adds one
/// byte per 254 and one more, then the 0x00 delimiter.
pub const fn frame_len(n: usize) -> usize {
    n + n / 254 + 1 + 1
}

/// Longest [`Command`] frame on the wire (the hub's receive buffer).
pub const COMMAND_FRAME_MAX: usize = frame_len(COMMAND_MAX_LEN);
/// Longest [`HubMessage`] frame on the wire (the hub's transmit buffer).
pub const HUB_FRAME_MAX: usize = frame_len(HUB_MESSAGE_MAX_LEN);

const _: () = assert!(CHUNK_MAX < 128); // length varint is one byte

/// Why a frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum FrameError {
    /// More bytes than the longest message before a 0x00: dropped up to the
    /// next 0x00.
    Overflow,
    /// Not valid COBS, not a valid message, or bytes left over.
    Malformed,
    /// The output buffer is too small to encode into.
    BufferTooSmall,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Overflow => "frame longer than the longest message",
            Self::Malformed => "frame does not decode",
            Self::BufferTooSmall => "buffer too small",
        })
    }
}

impl core::error::Error for FrameError {}

/// Encodes `msg` as one frame (COBS + 0x00) into `buf`; returns its length.
pub fn encode<T: Serialize>(msg: &T, buf: &mut [u8]) -> Result<usize, FrameError> {
    postcard::to_slice_cobs(msg, buf)
        .map(|b| b.len())
        .map_err(|_| FrameError::BufferTooSmall)
}

/// Decodes one frame's bytes (without its 0x00), in place: COBS, then
/// postcard, refusing bytes left over after the message (postcard's own
/// COBS helpers would ignore them).
pub fn decode<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
    let n = cobs_decode_in_place(frame).ok_or(FrameError::Malformed)?;
    let bytes = frame.get(..n).ok_or(FrameError::Malformed)?;
    match postcard::take_from_bytes::<T>(bytes) {
        Ok((msg, [])) => Ok(msg),
        _ => Err(FrameError::Malformed),
    }
}

/// COBS-decodes `buf` (one frame, no 0x00 in it) in place; returns the
/// decoded length, or `None` for invalid COBS (a 0x00 inside, or a code
/// byte pointing past the end). The output never overtakes the input.
fn cobs_decode_in_place(buf: &mut [u8]) -> Option<usize> {
    let (mut read, mut write) = (0usize, 0usize);
    while read < buf.len() {
        let code = *buf.get(read)?;
        if code == 0 {
            return None;
        }
        read += 1;
        for _ in 1..code {
            let b = *buf.get(read)?;
            if b == 0 {
                return None;
            }
            *buf.get_mut(write)? = b;
            read += 1;
            write += 1;
        }
        // A code below 0xFF stands for a zero, unless it ends the frame.
        if code != 0xFF && read < buf.len() {
            *buf.get_mut(write)? = 0;
            write += 1;
        }
    }
    Some(write)
}

/// Collects UART bytes into frames and decodes them. `N` is the longest
/// frame accepted (without the 0x00): [`COMMAND_FRAME_MAX`] on the hub,
/// [`HUB_FRAME_MAX`] on the host.
#[derive(Clone, Debug)]
pub struct FrameReader<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflow: bool,
}

impl<const N: usize> Default for FrameReader<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameReader<N> {
    /// An empty reader.
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflow: false,
        }
    }

    /// Takes one byte; at a 0x00 that ends a non-empty frame, returns the
    /// decoded message or why the frame was dropped. Repeated 0x00 bytes
    /// (idle line, resync) give nothing.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            match self.buf.get_mut(self.len) {
                Some(slot) if !self.overflow => {
                    *slot = byte;
                    self.len += 1;
                }
                _ => self.overflow = true,
            }
            return None;
        }
        let (len, overflow) = (self.len, self.overflow);
        self.len = 0;
        self.overflow = false;
        if overflow {
            return Some(Err(FrameError::Overflow));
        }
        if len == 0 {
            return None;
        }
        Some(
            self.buf
                .get_mut(..len)
                .map_or(Err(FrameError::Overflow), |frame| decode(frame)),
        )
    }

    /// Takes bytes as they came from the UART; calls `on_frame` once per
    /// completed frame, in order.
    pub fn feed<T: DeserializeOwned>(
        &mut self,
        bytes: &[u8],
        mut on_frame: impl FnMut(Result<T, FrameError>),
    ) {
        for &b in bytes {
            if let Some(r) = self.push(b) {
                on_frame(r);
            }
        }
    }
}

#[cfg(test)]
mod tests;
