//! The host's side of the serial protocol (`firmware::protocol`), over any
//! [`Link`]: one command at a time, each answered before the next is sent.
//!
//! The hub interleaves a `Telemetry` frame after every sample with its
//! replies; [`Session::request`] skips them (and any stale reply to an
//! earlier command) until the reply to the command just sent arrives.
//! Frames that do not decode are dropped and counted: COBS resynchronises
//! at the next 0x00.
//!
//! Upload (spec: `docs/wire-format.md`, "Model upload"): `Ping` (protocol
//! version), `UploadBegin` and **wait for its Ack** (the hub erases a
//! 128 KiB sector for 1-2 s with the CPU stalled, and bytes sent meanwhile
//! may be lost), then each `UploadChunk` waiting for its Ack, then
//! `UploadCommit`. A chunk with no answer in time, or answered
//! `Nack { Unknown, Malformed }` (garbled on the line), is sent once more; a
//! `Nack OutOfOrder` that says the hub already has the chunk (a late Ack
//! was lost or the first copy did arrive) counts as its Ack, and one that
//! names the chunk's own offset is the stale answer to a duplicate. Any
//! other Nack ends the upload with the hub's error, after a best-effort
//! `UploadAbort`.

use std::collections::VecDeque;
use std::fmt;
use std::io;
use std::time::{Duration, Instant};

use firmware::protocol::{
    encode, Command, CommandKind, ErrorCode, FrameReader, HubMessage, Telemetry, CHUNK_MAX,
    COMMAND_FRAME_MAX, HUB_FRAME_MAX, PROTOCOL_VERSION,
};

use super::link::Link;

/// How long one `read` of the link waits: the granularity of deadlines.
const POLL: Duration = Duration::from_millis(50);

/// Longest wait for the Ack of a chunk, a commit or a ping (capped by the
/// user's timeout). A chunk is 6 ms on the wire at 115200 baud and ~1 ms to
/// write; 2 s also covers a telemetry frame and a sample's work ahead of it.
pub const REPLY_TIMEOUT: Duration = Duration::from_secs(2);

/// Longest wait for the `UploadAbort` sent after a failure (best effort).
const ABORT_TIMEOUT: Duration = Duration::from_millis(500);

/// Why a session step failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum HubError {
    /// Reading or writing the link failed.
    Io(io::Error),
    /// No reply to `command` within `after`.
    Timeout {
        /// The command sent.
        command: CommandKind,
        /// How long we waited.
        after: Duration,
    },
    /// The hub refused `command`.
    Nack {
        /// The refused command.
        command: CommandKind,
        /// The hub's error.
        error: ErrorCode,
        /// The blob offset of a refused chunk.
        offset: Option<u32>,
    },
    /// The hub speaks another protocol version.
    Protocol {
        /// The hub's version.
        hub: u16,
    },
}

impl fmt::Display for HubError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io(e) => write!(f, "serial link: {e}"),
            Self::Timeout { command, after } => write!(
                f,
                "no answer from the hub to {command:?} within {:.1} s",
                after.as_secs_f64()
            ),
            Self::Nack {
                command,
                error,
                offset,
            } => {
                write!(f, "hub refused {command:?}")?;
                if let Some(o) = offset {
                    write!(f, " at offset {o}")?;
                }
                write!(f, ": {}", describe(error))
            }
            Self::Protocol { hub } => write!(
                f,
                "hub speaks protocol version {hub}, this thermcomp speaks {PROTOCOL_VERSION}"
            ),
        }
    }
}

impl std::error::Error for HubError {}

impl From<io::Error> for HubError {
    fn from(e: io::Error) -> Self {
        Self::Io(e)
    }
}

/// The hub's error code, named as on the wire and explained.
pub fn describe(e: &ErrorCode) -> String {
    match e {
        ErrorCode::Malformed => "Malformed (the frame did not decode)".into(),
        ErrorCode::Unsupported => "Unsupported (this hub build cannot do that)".into(),
        ErrorCode::NotUploading => "NotUploading (no upload in progress)".into(),
        ErrorCode::BadLength { max } => {
            format!("BadLength (the blob must be 16 to {max} bytes)")
        }
        ErrorCode::OutOfOrder { expected } => {
            format!("OutOfOrder (the hub expected offset {expected})")
        }
        ErrorCode::BadChunk => "BadChunk (empty, misaligned or overlong chunk)".into(),
        ErrorCode::Incomplete { received } => {
            format!("Incomplete (the hub received only {received} bytes)")
        }
        ErrorCode::CrcMismatch => {
            "CrcMismatch (the bytes in the hub's flash do not have the announced CRC)".into()
        }
        ErrorCode::BadBlob { reason } => {
            format!("BadBlob (reason {reason}: {})", blob_reason(*reason))
        }
        ErrorCode::Flash => "Flash (erasing, writing or reading back the flash failed)".into(),
        ErrorCode::OutOfRange => "OutOfRange (value outside its range)".into(),
        other => format!("{other:?}"),
    }
}

/// `ErrorCode::BadBlob` reasons (`firmware::upload::blob_reason`).
fn blob_reason(reason: u8) -> &'static str {
    match reason {
        1 => "too short",
        2 => "too long",
        3 => "bad magic",
        4 => "unsupported version",
        5 => "length mismatch",
        6 => "blob CRC",
        7 => "unknown kind",
        8 => "malformed body",
        9 => "invalid model",
        _ => "unknown",
    }
}

/// A reply to a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reply {
    /// `Ack` of the command.
    Ack,
    /// `Nack` of the command (or of an undecodable frame: `Unknown`).
    Nack(CommandKind, ErrorCode),
    /// `Pong` with the hub's protocol version.
    Pong(u16),
}

/// What an upload did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UploadReport {
    /// Blob bytes sent.
    pub bytes: u32,
    /// Chunks acknowledged.
    pub chunks: u32,
    /// Chunks sent a second time.
    pub retries: u32,
    /// zlib CRC-32 of the blob.
    pub crc32: u32,
}

/// Timeouts of an upload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timeouts {
    /// Wait for `UploadBegin`'s Ack (the erase).
    pub begin: Duration,
    /// Wait for any other reply.
    pub reply: Duration,
}

impl Timeouts {
    /// From the user's `--timeout-s`: the erase gets all of it, other
    /// replies at most [`REPLY_TIMEOUT`].
    pub fn from_user(timeout: Duration) -> Self {
        Self {
            begin: timeout,
            reply: timeout.min(REPLY_TIMEOUT),
        }
    }
}

/// A session with the hub over a link.
pub struct Session<L> {
    link: L,
    reader: FrameReader<HUB_FRAME_MAX>,
    inbox: VecDeque<HubMessage>,
    dropped: u32,
}

impl<L: Link> Session<L> {
    /// A session over `link` (sets its read timeout).
    pub fn new(mut link: L) -> Result<Self, HubError> {
        link.set_read_timeout(POLL)?;
        Ok(Self {
            link,
            reader: FrameReader::new(),
            inbox: VecDeque::new(),
            dropped: 0,
        })
    }

    /// Frames dropped because they did not decode.
    pub fn dropped_frames(&self) -> u32 {
        self.dropped
    }

    /// Gives the link back.
    pub fn into_inner(self) -> L {
        self.link
    }

    /// Sends one command frame.
    pub fn send(&mut self, command: &Command) -> Result<(), HubError> {
        let mut buf = [0u8; COMMAND_FRAME_MAX];
        let n = encode(command, &mut buf)
            .map_err(|e| HubError::Io(io::Error::new(io::ErrorKind::InvalidInput, e)))?;
        self.link.write_all(&buf[..n])?;
        self.link.flush()?;
        Ok(())
    }

    /// The next message from the hub, or `None` at `deadline`.
    pub fn next_message(&mut self, deadline: Instant) -> Result<Option<HubMessage>, HubError> {
        let mut buf = [0u8; 256];
        loop {
            if let Some(m) = self.inbox.pop_front() {
                return Ok(Some(m));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            let n = match self.link.read(&mut buf) {
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            };
            let (inbox, dropped) = (&mut self.inbox, &mut self.dropped);
            self.reader.feed::<HubMessage>(&buf[..n], |r| match r {
                Ok(m) => inbox.push_back(m),
                Err(_) => *dropped += 1,
            });
        }
    }

    /// The next telemetry frame (replies are skipped), or `None` at
    /// `deadline`.
    pub fn next_telemetry(&mut self, deadline: Instant) -> Result<Option<Telemetry>, HubError> {
        while let Some(m) = self.next_message(deadline)? {
            if let HubMessage::Telemetry(t) = m {
                return Ok(Some(t));
            }
        }
        Ok(None)
    }

    /// Waits for the reply to a command of kind `kind` (telemetry and
    /// replies to other commands are skipped).
    pub fn wait_reply(&mut self, kind: CommandKind, timeout: Duration) -> Result<Reply, HubError> {
        let deadline = Instant::now() + timeout;
        while let Some(m) = self.next_message(deadline)? {
            match m {
                HubMessage::Ack(k) if k == kind => return Ok(Reply::Ack),
                HubMessage::Nack { command, error }
                    if command == kind || command == CommandKind::Unknown =>
                {
                    return Ok(Reply::Nack(command, error))
                }
                HubMessage::Pong { protocol } if kind == CommandKind::Ping => {
                    return Ok(Reply::Pong(protocol))
                }
                _ => {}
            }
        }
        Err(HubError::Timeout {
            command: kind,
            after: timeout,
        })
    }

    /// Sends `command` and waits for its reply.
    pub fn request(&mut self, command: &Command, timeout: Duration) -> Result<Reply, HubError> {
        self.send(command)?;
        self.wait_reply(command.kind(), timeout)
    }

    /// Sends `command` and expects an Ack: a Nack becomes an error.
    pub fn expect_ack(&mut self, command: &Command, timeout: Duration) -> Result<(), HubError> {
        match self.request(command, timeout)? {
            Reply::Ack => Ok(()),
            Reply::Nack(command, error) => Err(HubError::Nack {
                command,
                error,
                offset: None,
            }),
            Reply::Pong(_) => Err(HubError::Io(io::Error::other("unexpected Pong"))),
        }
    }

    /// Pings the hub; returns its protocol version and the round trip.
    /// A different version is an error.
    pub fn ping(&mut self, timeout: Duration) -> Result<(u16, Duration), HubError> {
        let start = Instant::now();
        let reply = self.request(&Command::Ping, timeout)?;
        let rtt = start.elapsed();
        match reply {
            Reply::Pong(PROTOCOL_VERSION) => Ok((PROTOCOL_VERSION, rtt)),
            Reply::Pong(hub) => Err(HubError::Protocol { hub }),
            Reply::Nack(command, error) => Err(HubError::Nack {
                command,
                error,
                offset: None,
            }),
            Reply::Ack => Err(HubError::Io(io::Error::other("Ack instead of Pong"))),
        }
    }

    /// Sets the tool length, mm.
    pub fn set_tool(&mut self, mm: f32, timeout: Duration) -> Result<(), HubError> {
        self.expect_ack(&Command::SetToolLength { mm }, timeout)
    }

    /// Uploads `blob` (already checked by the caller) and commits it;
    /// `progress` gets the bytes acknowledged so far. On failure after
    /// `UploadBegin`, sends `UploadAbort` (best effort) before returning.
    pub fn upload(
        &mut self,
        blob: &[u8],
        timeouts: Timeouts,
        progress: &mut dyn FnMut(u32),
    ) -> Result<UploadReport, HubError> {
        let len = u32::try_from(blob.len()).map_err(|_| HubError::Nack {
            command: CommandKind::UploadBegin,
            error: ErrorCode::BadLength { max: u32::MAX },
            offset: None,
        })?;
        let crc32 = model_core::blob::crc32(blob);
        self.ping(timeouts.reply)?;
        // Never send anything before this Ack: the erase stalls the hub.
        match self.request(&Command::UploadBegin { len, crc32 }, timeouts.begin) {
            Ok(Reply::Ack) => {}
            Ok(Reply::Nack(command, error)) => {
                return Err(HubError::Nack {
                    command,
                    error,
                    offset: None,
                })
            }
            Ok(Reply::Pong(_)) => return Err(HubError::Io(io::Error::other("unexpected Pong"))),
            Err(e) => {
                self.abort();
                return Err(e);
            }
        }
        let result =
            self.send_chunks(blob, timeouts.reply, progress)
                .and_then(|(chunks, retries)| {
                    self.expect_ack(&Command::UploadCommit, timeouts.reply)?;
                    Ok(UploadReport {
                        bytes: len,
                        chunks,
                        retries,
                        crc32,
                    })
                });
        if result.is_err() {
            self.abort();
        }
        result
    }

    /// Sends every chunk, each acknowledged; returns (chunks, retries).
    fn send_chunks(
        &mut self,
        blob: &[u8],
        timeout: Duration,
        progress: &mut dyn FnMut(u32),
    ) -> Result<(u32, u32), HubError> {
        let (mut chunks, mut retries) = (0u32, 0u32);
        for (i, bytes) in blob.chunks(CHUNK_MAX).enumerate() {
            let offset = (i * CHUNK_MAX) as u32;
            let end = offset + bytes.len() as u32;
            let command = Command::UploadChunk {
                offset,
                bytes: heapless::Vec::from_slice(bytes)
                    .map_err(|_| HubError::Io(io::Error::other("chunk longer than CHUNK_MAX")))?,
            };
            let mut attempts = 0;
            'send: loop {
                self.send(&command)?;
                attempts += 1;
                let give_up = attempts >= 2;
                loop {
                    match self.wait_reply(CommandKind::UploadChunk, timeout) {
                        Ok(Reply::Ack) => break 'send,
                        // The hub already has this chunk (the first copy
                        // arrived; its Ack was lost or late).
                        Ok(Reply::Nack(_, ErrorCode::OutOfOrder { expected }))
                            if expected == end =>
                        {
                            break 'send
                        }
                        // The stale answer to a duplicate of the previous
                        // chunk: the hub is waiting for exactly this one.
                        Ok(Reply::Nack(_, ErrorCode::OutOfOrder { expected }))
                            if expected == offset => {}
                        Ok(Reply::Nack(CommandKind::Unknown, ErrorCode::Malformed))
                        | Err(HubError::Timeout { .. })
                            if !give_up =>
                        {
                            retries += 1;
                            continue 'send;
                        }
                        Ok(Reply::Nack(command, error)) => {
                            return Err(HubError::Nack {
                                command,
                                error,
                                offset: Some(offset),
                            })
                        }
                        Ok(Reply::Pong(_)) => {}
                        Err(HubError::Timeout { command, after }) => {
                            return Err(HubError::Timeout {
                                command,
                                after: after * attempts,
                            })
                        }
                        Err(e) => return Err(e),
                    }
                }
            }
            chunks += 1;
            progress(end);
        }
        Ok((chunks, retries))
    }

    /// Best-effort `UploadAbort` (so the hub clears its upload state and
    /// the UPLOADING flag); errors are ignored.
    fn abort(&mut self) {
        let _ = self.request(&Command::UploadAbort, ABORT_TIMEOUT);
    }
}

#[cfg(test)]
mod tests;
