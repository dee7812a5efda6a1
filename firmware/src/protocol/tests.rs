//! Exact bytes, round trips, byte-by-byte feeding and garbage resilience.
//! Expected bytes were computed independently (a 20-line Python COBS and
//! varint encoder, kept in `docs/wire-format.md`'s examples).

use super::*;
use crate::report::{HubState, StatusFlags};
use proptest::prelude::*;

type HubReader = FrameReader<COMMAND_FRAME_MAX>;
type HostReader = FrameReader<HUB_FRAME_MAX>;

fn frame<T: Serialize>(msg: &T) -> std::vec::Vec<u8> {
    let mut buf = [0u8; HUB_FRAME_MAX];
    let n = encode(msg, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn chunk(offset: u32, bytes: &[u8]) -> Command {
    Command::UploadChunk {
        offset,
        bytes: heapless::Vec::from_slice(bytes).unwrap(),
    }
}

fn read_all<T: DeserializeOwned, const N: usize>(
    bytes: &[u8],
) -> std::vec::Vec<Result<T, FrameError>> {
    let mut r = FrameReader::<N>::new();
    let mut out = std::vec::Vec::new();
    r.feed(bytes, |m| out.push(m));
    out
}

#[test]
fn exact_bytes() {
    assert_eq!(frame(&Command::Ping), [0x01, 0x01, 0x00]);
    assert_eq!(
        frame(&Command::UploadBegin {
            len: 300,
            crc32: 0xCBF4_3926
        }),
        [0x09, 0x01, 0xAC, 0x02, 0xA6, 0xF2, 0xD0, 0xDF, 0x0C, 0x00]
    );
    assert_eq!(
        frame(&chunk(64, &[0, 1, 2, 3])),
        [0x04, 0x02, 0x40, 0x04, 0x04, 0x01, 0x02, 0x03, 0x00]
    );
    assert_eq!(
        frame(&Command::SetToolLength { mm: 100.0 }),
        [0x02, 0x05, 0x01, 0x03, 0xC8, 0x42, 0x00]
    );
    assert_eq!(
        frame(&HubMessage::Nack {
            command: CommandKind::UploadChunk,
            error: ErrorCode::OutOfOrder { expected: 128 }
        }),
        [0x06, 0x02, 0x02, 0x04, 0x80, 0x01, 0x00]
    );
    assert_eq!(
        frame(&HubMessage::Pong { protocol: 1 }),
        [0x03, 0x03, 0x01, 0x00]
    );
}

fn telemetry_max() -> HubMessage {
    let report = Report {
        seq: u32::MAX,
        offsets: [-499.9, 12.5, f64::NAN, 1e30],
        n_outputs: 4,
        state: HubState::Zeroed,
        flags: StatusFlags(u16::MAX),
        faulty_channels: u32::MAX,
        ..Report::default()
    };
    HubMessage::Telemetry(Telemetry::new(&report, &[25.5; 40]))
}

#[test]
fn largest_messages_fit_the_declared_sizes() {
    // The longest of each kind, encoded: exactly the declared maximum.
    let mut buf = [0u8; 256];
    let n = postcard::to_slice(&chunk(u32::MAX, &[0xAA; CHUNK_MAX]), &mut buf)
        .unwrap()
        .len();
    assert_eq!(n, COMMAND_MAX_LEN);
    let n = postcard::to_slice(&telemetry_max(), &mut buf)
        .unwrap()
        .len();
    assert_eq!(n, HUB_MESSAGE_MAX_LEN);
    // And the frames fit the buffers (COBS of no zeros is the worst case).
    assert!(frame(&chunk(u32::MAX, &[0xAA; CHUNK_MAX])).len() <= COMMAND_FRAME_MAX);
    assert!(frame(&telemetry_max()).len() <= HUB_FRAME_MAX);
    // Anything else is shorter.
    for c in [
        Command::Ping,
        Command::UploadBegin {
            len: u32::MAX,
            crc32: u32::MAX,
        },
        Command::UploadCommit,
        Command::UploadAbort,
        Command::SetToolLength { mm: f32::MAX },
    ] {
        assert!(postcard::to_slice(&c, &mut buf).unwrap().len() <= COMMAND_MAX_LEN);
    }
}

#[test]
fn round_trips_through_the_readers() {
    let cmds = [
        Command::Ping,
        Command::UploadBegin {
            len: 16_384,
            crc32: 7,
        },
        chunk(0, &[0; CHUNK_MAX]),
        chunk(u32::MAX, &[0xFF; 1]),
        Command::UploadCommit,
        Command::UploadAbort,
        Command::SetToolLength { mm: 123.25 },
    ];
    let mut stream = std::vec::Vec::new();
    for c in &cmds {
        stream.extend(frame(c));
    }
    let got = read_all::<Command, COMMAND_FRAME_MAX>(&stream);
    assert_eq!(
        got,
        cmds.iter().cloned().map(Ok).collect::<std::vec::Vec<_>>()
    );

    let msgs = [
        telemetry_max(),
        HubMessage::Ack(CommandKind::UploadCommit),
        HubMessage::Nack {
            command: CommandKind::Unknown,
            error: ErrorCode::BadBlob { reason: 6 },
        },
    ];
    let mut stream = std::vec::Vec::new();
    for m in &msgs {
        stream.extend(frame(m));
    }
    let got = read_all::<HubMessage, HUB_FRAME_MAX>(&stream);
    // NaN != NaN: compare the encodings instead.
    assert_eq!(got.len(), msgs.len());
    for (g, m) in got.iter().zip(&msgs) {
        assert_eq!(frame(g.as_ref().unwrap()), frame(m));
    }
}

#[test]
fn telemetry_carries_the_report() {
    let report = Report {
        seq: 7,
        offsets: [1.5, -2.25, 0.0, 0.0],
        n_outputs: 2,
        state: HubState::Running,
        flags: StatusFlags(StatusFlags::SLEW_LIMITED),
        faulty_channels: 0b10,
        ..Report::default()
    };
    let t = Telemetry::new(&report, &[20.0, f64::NAN]);
    assert_eq!(t.offsets_um, [1.5, -2.25, 0.0, 0.0]);
    assert_eq!((t.seq, t.n_outputs, t.state, t.flags), (7, 2, 1, 1 << 5));
    assert_eq!(t.temps_c.len(), 2);
    assert!(t.temps_c[1].is_nan());
}

#[test]
fn garbage_between_frames_costs_only_that_frame() {
    let mut stream = vec![0x13, 0x37, 0xFF, 0x00]; // not a command
    stream.extend(frame(&Command::Ping));
    stream.extend([0x00, 0x00]); // idle delimiters
    stream.extend([0x05; 200]); // overlong run
    stream.push(0x00);
    stream.extend(frame(&Command::UploadAbort));
    let got = read_all::<Command, COMMAND_FRAME_MAX>(&stream);
    assert_eq!(
        got,
        [
            Err(FrameError::Malformed),
            Ok(Command::Ping),
            Err(FrameError::Overflow),
            Ok(Command::UploadAbort)
        ]
    );
}

#[test]
fn trailing_bytes_after_a_message_are_refused() {
    // A valid Ping (0x00) followed by an extra byte, COBS-encoded.
    let got = read_all::<Command, COMMAND_FRAME_MAX>(&[0x01, 0x02, 0x07, 0x00]);
    assert_eq!(got, [Err(FrameError::Malformed)]);
}

#[test]
fn chunk_longer_than_chunk_max_is_refused() {
    // Hand-built: variant 2, offset 0, length 65, 65 x 0xAA.
    let mut raw = vec![2u8, 0, 65];
    raw.extend([0xAA; 65]);
    let mut buf = [0u8; 128];
    let n = cobs_encode(&raw, &mut buf);
    let got = read_all::<Command, COMMAND_FRAME_MAX>(&buf[..n]);
    assert_eq!(got, [Err(FrameError::Malformed)]);
}

/// Minimal COBS encoder (+ 0x00) for hand-built frames.
fn cobs_encode(data: &[u8], out: &mut [u8]) -> usize {
    let mut code_at = 0;
    let mut n = 1;
    let mut code = 1u8;
    for &b in data {
        if b == 0 || code == 0xFF {
            out[code_at] = code;
            code_at = n;
            n += 1;
            code = 1;
            if b == 0 {
                continue;
            }
        }
        out[n] = b;
        n += 1;
        code += 1;
    }
    out[code_at] = code;
    out[n] = 0;
    n + 1
}

proptest! {
    #[test]
    fn any_split_of_the_stream_gives_the_same_commands(
        offsets in proptest::collection::vec(any::<u32>(), 1..6),
        data in proptest::collection::vec(any::<u8>(), 1..=CHUNK_MAX),
        cuts in proptest::collection::vec(0usize..400, 0..8),
    ) {
        let cmds: std::vec::Vec<Command> = offsets.iter().map(|&o| chunk(o, &data)).collect();
        let mut stream = std::vec::Vec::new();
        for c in &cmds {
            stream.extend(frame(c));
        }
        let mut cuts: std::vec::Vec<usize> = cuts.into_iter().map(|c| c % (stream.len() + 1)).collect();
        cuts.sort_unstable();
        let mut reader = HubReader::new();
        let mut got = std::vec::Vec::new();
        let mut start = 0;
        for cut in cuts.into_iter().chain([stream.len()]) {
            reader.feed(&stream[start..cut], |m| got.push(m));
            start = cut;
        }
        prop_assert_eq!(got, cmds.into_iter().map(Ok).collect::<std::vec::Vec<_>>());
    }

    #[test]
    fn garbage_never_panics_and_the_next_frame_decodes(
        garbage in proptest::collection::vec(any::<u8>(), 0..600),
    ) {
        let mut reader = HostReader::new();
        reader.feed::<HubMessage>(&garbage, |_| {});
        // One delimiter resyncs; the next frame is intact.
        let mut got = std::vec::Vec::new();
        reader.feed::<HubMessage>(&[0], |_| {});
        reader.feed(&frame(&HubMessage::Ack(CommandKind::Ping)), |m| got.push(m));
        prop_assert_eq!(got, vec![Ok(HubMessage::Ack(CommandKind::Ping))]);
        let mut hub = HubReader::new();
        hub.feed::<Command>(&garbage, |_| {});
    }
}
