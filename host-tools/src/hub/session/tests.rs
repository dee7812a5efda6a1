//! The session against a scripted hub: an in-memory [`Link`] that decodes
//! each command frame the session writes and queues the replies a script
//! gives for it (exact command sequences, retries, stale replies).

use super::*;
use firmware::protocol::{Telemetry, COMMAND_FRAME_MAX};
use std::io::{Read, Write};

type Script = Box<dyn FnMut(&Command, &[Command]) -> Vec<HubMessage>>;

struct ScriptLink {
    reader: FrameReader<COMMAND_FRAME_MAX>,
    inbox: VecDeque<u8>,
    sent: Vec<Command>,
    script: Script,
}

impl ScriptLink {
    fn new(script: impl FnMut(&Command, &[Command]) -> Vec<HubMessage> + 'static) -> Self {
        Self {
            reader: FrameReader::new(),
            inbox: VecDeque::new(),
            sent: Vec::new(),
            script: Box::new(script),
        }
    }
}

impl Read for ScriptLink {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.inbox.is_empty() {
            std::thread::sleep(Duration::from_millis(1));
            return Ok(0);
        }
        let n = buf.len().min(self.inbox.len());
        for (b, x) in buf.iter_mut().zip(self.inbox.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}

impl Write for ScriptLink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let mut commands = Vec::new();
        self.reader.feed::<Command>(buf, |r| {
            commands.push(r.expect("session sends valid frames"))
        });
        for c in commands {
            let replies = (self.script)(&c, &self.sent);
            self.sent.push(c);
            for r in replies {
                let mut frame = [0u8; firmware::protocol::HUB_FRAME_MAX];
                let n = encode(&r, &mut frame).unwrap();
                self.inbox.extend(&frame[..n]);
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Link for ScriptLink {
    fn set_read_timeout(&mut self, _: Duration) -> io::Result<()> {
        Ok(())
    }
}

fn telemetry(seq: u32) -> HubMessage {
    HubMessage::Telemetry(Telemetry {
        seq,
        offsets_um: [1.5, -2.0, 0.0, 0.0],
        n_outputs: 2,
        state: 1,
        flags: 0,
        faulty_channels: 0,
        temps_c: heapless::Vec::from_slice(&[20.5, 21.0]).unwrap(),
    })
}

/// A hub that answers everything correctly, with a telemetry frame in
/// front of every reply.
fn good(c: &Command) -> Vec<HubMessage> {
    let reply = match c {
        Command::Ping => HubMessage::Pong {
            protocol: PROTOCOL_VERSION,
        },
        c => HubMessage::Ack(c.kind()),
    };
    vec![telemetry(7), reply]
}

/// How many copies of the chunk at `offset` were sent before.
fn copies(sent: &[Command], at: u32) -> usize {
    sent.iter()
        .filter(|c| matches!(c, Command::UploadChunk { offset, .. } if *offset == at))
        .count()
}

const FAST: Timeouts = Timeouts {
    begin: Duration::from_millis(300),
    reply: Duration::from_millis(100),
};

fn blob(n: usize) -> Vec<u8> {
    (0..n).map(|i| (i * 7 + 1) as u8).collect()
}

fn upload(link: ScriptLink, blob: &[u8]) -> (Result<UploadReport, HubError>, Vec<Command>, u32) {
    let mut s = Session::new(link).unwrap();
    let mut last = 0;
    let r = s.upload(blob, FAST, &mut |n| last = n);
    (r, s.into_inner().sent, last)
}

fn reassemble(sent: &[Command]) -> Vec<u8> {
    let mut out = Vec::new();
    for c in sent {
        if let Command::UploadChunk { offset, bytes } = c {
            assert_eq!(*offset as usize, out.len(), "contiguous chunks");
            out.extend_from_slice(bytes);
        }
    }
    out
}

#[test]
fn upload_sends_ping_begin_chunks_commit_and_skips_telemetry() {
    let b = blob(150);
    let (r, sent, progress) = upload(ScriptLink::new(|c, _| good(c)), &b);
    let r = r.unwrap();
    assert_eq!(
        r,
        UploadReport {
            bytes: 150,
            chunks: 3,
            retries: 0,
            crc32: model_core::blob::crc32(&b)
        }
    );
    assert_eq!(progress, 150);
    assert_eq!(sent[0], Command::Ping);
    assert_eq!(
        sent[1],
        Command::UploadBegin {
            len: 150,
            crc32: model_core::blob::crc32(&b)
        }
    );
    assert_eq!(sent.len(), 6);
    assert_eq!(sent[5], Command::UploadCommit);
    assert_eq!(reassemble(&sent), b);
}

#[test]
fn a_chunk_without_answer_is_sent_once_more() {
    let link = ScriptLink::new(|c, sent| match c {
        Command::UploadChunk { offset: 64, .. } if copies(sent, 64) == 0 => vec![],
        c => good(c),
    });
    let (r, sent, _) = upload(link, &blob(150));
    assert_eq!(r.unwrap().retries, 1);
    assert_eq!(copies(&sent, 64), 2);
    assert_eq!(sent.last(), Some(&Command::UploadCommit));
}

#[test]
fn a_chunk_twice_without_answer_fails_and_aborts() {
    let link = ScriptLink::new(|c, _| match c {
        Command::UploadChunk { offset: 64, .. } => vec![],
        c => good(c),
    });
    let (r, sent, progress) = upload(link, &blob(150));
    let e = r.unwrap_err();
    assert!(
        matches!(
            e,
            HubError::Timeout {
                command: CommandKind::UploadChunk,
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(copies(&sent, 64), 2);
    assert_eq!(sent.last(), Some(&Command::UploadAbort));
    assert_eq!(progress, 64);
}

#[test]
fn a_late_ack_and_the_stale_nack_of_the_duplicate_are_sorted_out() {
    // First copy of chunk 64: the hub writes it but its Ack is late, so it
    // arrives after the retry; the retry itself is refused as out of order.
    let link = ScriptLink::new(|c, sent| match c {
        Command::UploadChunk { offset: 64, .. } if copies(sent, 64) == 0 => vec![],
        Command::UploadChunk { offset: 64, .. } => vec![
            HubMessage::Ack(CommandKind::UploadChunk),
            HubMessage::Nack {
                command: CommandKind::UploadChunk,
                error: ErrorCode::OutOfOrder { expected: 128 },
            },
        ],
        c => good(c),
    });
    let b = blob(150);
    let (r, sent, _) = upload(link, &b);
    assert_eq!(r.unwrap().retries, 1);
    assert_eq!(copies(&sent, 128), 1, "chunk 128 sent once: {sent:?}");
    assert_eq!(sent.last(), Some(&Command::UploadCommit));
}

#[test]
fn out_of_order_at_the_chunk_end_means_the_hub_has_it() {
    let link = ScriptLink::new(|c, sent| match c {
        Command::UploadChunk { offset: 64, .. } if copies(sent, 64) == 0 => vec![],
        Command::UploadChunk { offset: 64, .. } => vec![HubMessage::Nack {
            command: CommandKind::UploadChunk,
            error: ErrorCode::OutOfOrder { expected: 128 },
        }],
        c => good(c),
    });
    let (r, sent, _) = upload(link, &blob(150));
    assert_eq!(r.unwrap().chunks, 3);
    assert_eq!(sent.last(), Some(&Command::UploadCommit));
}

#[test]
fn a_garbled_chunk_is_resent() {
    let link = ScriptLink::new(|c, sent| match c {
        Command::UploadChunk { offset: 0, .. } if copies(sent, 0) == 0 => vec![HubMessage::Nack {
            command: CommandKind::Unknown,
            error: ErrorCode::Malformed,
        }],
        c => good(c),
    });
    let (r, _, _) = upload(link, &blob(100));
    assert_eq!(r.unwrap().retries, 1);
}

#[test]
fn a_nack_ends_the_upload_with_the_hubs_error() {
    let link = ScriptLink::new(|c, _| match c {
        Command::UploadChunk { offset: 64, .. } => vec![HubMessage::Nack {
            command: CommandKind::UploadChunk,
            error: ErrorCode::Flash,
        }],
        c => good(c),
    });
    let (r, sent, _) = upload(link, &blob(150));
    let msg = r.unwrap_err().to_string();
    assert_eq!(
        msg,
        "hub refused UploadChunk at offset 64: Flash (erasing, writing or reading back the flash failed)"
    );
    assert_eq!(copies(&sent, 64), 1, "a Nack is not retried");
    assert_eq!(sent.last(), Some(&Command::UploadAbort));
}

#[test]
fn a_refused_commit_names_the_blob_reason() {
    let link = ScriptLink::new(|c, _| match c {
        Command::UploadCommit => vec![HubMessage::Nack {
            command: CommandKind::UploadCommit,
            error: ErrorCode::BadBlob { reason: 6 },
        }],
        c => good(c),
    });
    let msg = upload(link, &blob(70)).0.unwrap_err().to_string();
    assert!(
        msg.contains("UploadCommit") && msg.contains("reason 6: blob CRC"),
        "{msg}"
    );
}

#[test]
fn a_hub_with_another_protocol_gets_nothing_else() {
    let link = ScriptLink::new(|c, _| match c {
        Command::Ping => vec![HubMessage::Pong { protocol: 2 }],
        c => good(c),
    });
    let (r, sent, _) = upload(link, &blob(70));
    assert!(matches!(r, Err(HubError::Protocol { hub: 2 })));
    assert_eq!(sent, vec![Command::Ping]);
}

#[test]
fn no_ack_for_begin_sends_no_chunk() {
    let link = ScriptLink::new(|c, _| match c {
        Command::UploadBegin { .. } => vec![],
        c => good(c),
    });
    let (r, sent, _) = upload(link, &blob(70));
    assert!(matches!(
        r,
        Err(HubError::Timeout {
            command: CommandKind::UploadBegin,
            ..
        })
    ));
    assert!(!sent
        .iter()
        .any(|c| matches!(c, Command::UploadChunk { .. })));
}

#[test]
fn set_tool_then_telemetry_after_the_reply() {
    let link = ScriptLink::new(|c, _| vec![HubMessage::Ack(c.kind()), telemetry(9)]);
    let mut s = Session::new(link).unwrap();
    s.set_tool(123.4, Duration::from_millis(100)).unwrap();
    let t = s
        .next_telemetry(Instant::now() + Duration::from_millis(100))
        .unwrap()
        .expect("the telemetry after the Ack is kept");
    assert_eq!(t.seq, 9);
    assert_eq!(
        s.into_inner().sent,
        vec![Command::SetToolLength { mm: 123.4 }]
    );
}

#[test]
fn every_error_code_is_named() {
    for (e, name) in [
        (ErrorCode::Malformed, "Malformed"),
        (ErrorCode::Unsupported, "Unsupported"),
        (ErrorCode::NotUploading, "NotUploading"),
        (ErrorCode::BadLength { max: 9 }, "BadLength"),
        (ErrorCode::OutOfOrder { expected: 64 }, "OutOfOrder"),
        (ErrorCode::BadChunk, "BadChunk"),
        (ErrorCode::Incomplete { received: 3 }, "Incomplete"),
        (ErrorCode::CrcMismatch, "CrcMismatch"),
        (ErrorCode::BadBlob { reason: 9 }, "BadBlob"),
        (ErrorCode::Flash, "Flash"),
        (ErrorCode::OutOfRange, "OutOfRange"),
    ] {
        assert!(describe(&e).starts_with(name), "{e:?}");
    }
}
