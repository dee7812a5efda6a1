//! The board's command handling on the host: a pipeline, an uploader over
//! RAM flash with the board's slot geometry, and the commands a `thermcomp
//! hub` session sends.

use super::*;
use crate::hub::Hub;
use crate::pipeline::{PipelineConfig, Reading};
use crate::protocol::CHUNK_MAX;
use crate::ram_flash::HeapFlash;
use crate::report::{HubState, StatusFlags};
use crate::test_util::{name, vec};
use crate::upload::SlotMap;
use model_core::blob::crc32;
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::{Channel, Model, Reference, ValidModel};

const SLOT: u32 = 128 * 1024;
const MAP: SlotMap = SlotMap {
    a: 0,
    b: SLOT,
    len: SLOT,
};

/// dz = intercept + 0.5 T1 (the intercept tells models apart).
fn model(intercept: f64) -> ValidModel {
    Model {
        inputs: vec(&[Channel {
            name: name("T1"),
            reference: Reference::Absolute,
        }]),
        outputs: vec(&[name("dz_um")]),
        dt_s: 0.0,
        params: model_core::Params::Linear(Linear {
            outputs: vec(&[LinearOutput {
                output: 0,
                intercept,
                coef: vec(&[Coef {
                    channel: 0,
                    value: 0.5,
                }]),
                position: None,
            }]),
        }),
        bounds: None,
        five_point: None,
    }
    .validate()
    .unwrap()
}

fn blob(intercept: f64) -> std::vec::Vec<u8> {
    crate::test_util::blob(&model(intercept))
}

/// A hub running `dz = 1 + 0.5 T1` from slot A, and its uploader.
fn hub() -> (Pipeline, Uploader<HeapFlash>) {
    let running = Hub::load(&blob(1.0));
    let pipeline = Pipeline::new(running, PipelineConfig::DEFAULT).unwrap();
    let uploader = Uploader::new(HeapFlash::new(2 * SLOT as usize), MAP, Some(Slot::A));
    (pipeline, uploader)
}

/// Runs `cmd`; the reply, the event and how often the erase hook ran.
fn run(p: &mut Pipeline, u: &mut Uploader<HeapFlash>, cmd: &Command) -> (HubMessage, Event, usize) {
    let mut fed = 0;
    let (reply, event) = execute(p, u, || fed += 1, cmd);
    (reply, event, fed)
}

/// The model's steady output at T1 = 20 C once the slew limiter caught up.
fn settled_dz(p: &mut Pipeline) -> f64 {
    let mut last = f64::NAN;
    for _ in 0..600 {
        last = p.on_sample(&[Reading::Value(20.0)]).offsets[0];
    }
    last
}

fn chunks(b: &[u8]) -> impl Iterator<Item = Command> + '_ {
    b.chunks(CHUNK_MAX)
        .enumerate()
        .map(|(i, c)| Command::UploadChunk {
            offset: (i * CHUNK_MAX) as u32,
            bytes: heapless::Vec::from_slice(c).unwrap(),
        })
}

#[test]
fn ping_answers_the_protocol_version() {
    let (mut p, mut u) = hub();
    let (reply, event, fed) = run(&mut p, &mut u, &Command::Ping);
    assert_eq!(
        reply,
        HubMessage::Pong {
            protocol: PROTOCOL_VERSION
        }
    );
    assert_eq!((event, fed), (Event::None, 0));
}

#[test]
fn tool_length_is_set_or_refused_keeping_the_old_one() {
    let (mut p, mut u) = hub();
    let set = |mm| Command::SetToolLength { mm };
    assert_eq!(
        run(&mut p, &mut u, &set(120.5)).0,
        HubMessage::Ack(CommandKind::SetToolLength)
    );
    assert_eq!(p.tool_length_mm(), Some(120.5));
    for bad in [-1.0, f32::NAN, f32::INFINITY, 1.0e6] {
        assert_eq!(
            run(&mut p, &mut u, &set(bad)).0,
            HubMessage::Nack {
                command: CommandKind::SetToolLength,
                error: ErrorCode::OutOfRange
            },
            "{bad}"
        );
        assert_eq!(p.tool_length_mm(), Some(120.5), "{bad} kept the old length");
    }
}

/// Begin feeds the watchdog once, right before the erase, and the reports
/// say UPLOADING until the commit; the committed model then runs (its
/// offset reached through the slew limiter) from slot B.
#[test]
fn an_upload_swaps_the_new_model_in_and_flags_while_in_progress() {
    let (mut p, mut u) = hub();
    assert!(
        (settled_dz(&mut p) - 11.0).abs() < 1e-9,
        "old model: 1 + 0.5 x 20"
    );
    let b = blob(4.0);
    let begin = Command::UploadBegin {
        len: b.len() as u32,
        crc32: crc32(&b),
    };
    let (reply, event, fed) = run(&mut p, &mut u, &begin);
    assert_eq!(reply, HubMessage::Ack(CommandKind::UploadBegin));
    assert_eq!(
        (event, fed),
        (
            Event::Erased {
                len: b.len() as u32
            },
            1
        )
    );
    let r = p.on_sample(&[Reading::Value(20.0)]);
    assert!(r.flags.has(StatusFlags::UPLOADING));
    for chunk in chunks(&b) {
        let (reply, event, fed) = run(&mut p, &mut u, &chunk);
        assert_eq!(reply, HubMessage::Ack(CommandKind::UploadChunk));
        assert_eq!((event, fed), (Event::None, 0));
    }
    let (reply, event, _) = run(&mut p, &mut u, &Command::UploadCommit);
    assert_eq!(reply, HubMessage::Ack(CommandKind::UploadCommit));
    assert_eq!(event, Event::Swapped { slot: Slot::B });
    let r = p.on_sample(&[Reading::Value(20.0)]);
    assert!(!r.flags.has(StatusFlags::UPLOADING));
    assert_eq!(r.state, HubState::Running);
    assert!(
        (settled_dz(&mut p) - 14.0).abs() < 1e-9,
        "new model: 4 + 0.5 x 20"
    );
}

/// A blob damaged in transit (CRC announced for the good one) is refused at
/// commit; the running model stays and UPLOADING clears.
#[test]
fn a_corrupted_upload_is_refused_and_the_running_model_stays() {
    let (mut p, mut u) = hub();
    let good = blob(4.0);
    let mut bad = good.clone();
    bad[20] ^= 0x01;
    let begin = Command::UploadBegin {
        len: good.len() as u32,
        crc32: crc32(&good),
    };
    assert_eq!(
        run(&mut p, &mut u, &begin).0,
        HubMessage::Ack(CommandKind::UploadBegin)
    );
    for chunk in chunks(&bad) {
        run(&mut p, &mut u, &chunk);
    }
    let (reply, event, _) = run(&mut p, &mut u, &Command::UploadCommit);
    assert_eq!(
        reply,
        HubMessage::Nack {
            command: CommandKind::UploadCommit,
            error: ErrorCode::CrcMismatch
        }
    );
    assert_eq!(event, Event::None);
    assert!(!p
        .on_sample(&[Reading::Value(20.0)])
        .flags
        .has(StatusFlags::UPLOADING));
    assert!(
        (settled_dz(&mut p) - 11.0).abs() < 1e-9,
        "old model still runs"
    );
}

/// A blob whose CRCs are right and whose body decodes, but whose model is
/// invalid (a NaN intercept), is refused at commit by the same decode that
/// would load it: the running model stays, and the slot never boots.
#[test]
fn an_upload_that_decodes_but_is_invalid_is_refused_and_never_boots() {
    let (mut p, mut u) = hub();
    let mut m = model(4.0).model().clone();
    if let model_core::Params::Linear(lin) = &mut m.params {
        lin.outputs[0].intercept = f64::NAN;
    }
    let bad = crate::test_util::unvalidated_blob(&m);
    assert_eq!(
        model_core::decode(&bad).unwrap_err(),
        model_core::BlobError::Invalid(model_core::ModelError::NonFinite)
    );
    let begin = Command::UploadBegin {
        len: bad.len() as u32,
        crc32: crc32(&bad),
    };
    run(&mut p, &mut u, &begin);
    for chunk in chunks(&bad) {
        run(&mut p, &mut u, &chunk);
    }
    let (reply, event, _) = run(&mut p, &mut u, &Command::UploadCommit);
    assert!(
        matches!(
            reply,
            HubMessage::Nack {
                command: CommandKind::UploadCommit,
                error: ErrorCode::BadBlob { .. }
            }
        ),
        "{reply:?}"
    );
    assert_eq!(event, Event::None);
    assert!((settled_dz(&mut p) - 11.0).abs() < 1e-9, "old model runs");
    // The upload went to slot B (A runs): B holds no bootable generation.
    assert_eq!(u.target(), Slot::B);
    assert_eq!(
        crate::upload::slot_generation(Slot::B, u.slot_bytes(Slot::B)),
        None,
        "the refused upload never boots"
    );
}

/// A chunk or commit with no upload, and a refused begin (too long), leave
/// no UPLOADING flag behind and never feed-and-erase for nothing.
#[test]
fn refused_upload_commands_leave_no_flag() {
    let (mut p, mut u) = hub();
    let chunk = chunks(&blob(4.0)).next().unwrap();
    for cmd in [chunk, Command::UploadCommit] {
        let (reply, event, fed) = run(&mut p, &mut u, &cmd);
        assert_eq!(
            reply,
            HubMessage::Nack {
                command: cmd.kind(),
                error: ErrorCode::NotUploading
            }
        );
        assert_eq!((event, fed), (Event::None, 0));
    }
    let too_long = Command::UploadBegin {
        len: 1 << 20,
        crc32: 0,
    };
    let (reply, event, _) = run(&mut p, &mut u, &too_long);
    assert!(matches!(
        reply,
        HubMessage::Nack {
            error: ErrorCode::BadLength { .. },
            ..
        }
    ));
    assert_eq!(event, Event::None);
    assert!(!p
        .on_sample(&[Reading::Value(20.0)])
        .flags
        .has(StatusFlags::UPLOADING));
    assert_eq!(u.into_inner().erases, 0);
}
