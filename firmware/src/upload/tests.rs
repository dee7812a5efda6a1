//! The upload against an in-memory NOR flash with the board's slot
//! geometry, including power cuts ("reboot" = `select_boot_slot` on what
//! the flash holds).

use super::*;
use crate::hub::Hub;
use crate::ram_flash::HeapFlash;
use crate::test_util::{name, vec};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::{Channel, Model, Params, Reference, ValidModel};

const SLOT: u32 = 128 * 1024;

const MAP: SlotMap = SlotMap {
    a: 0,
    b: SLOT,
    len: SLOT,
};

fn flash() -> HeapFlash {
    HeapFlash::new(2 * SLOT as usize)
}

fn slots(f: &HeapFlash) -> (&[u8], &[u8]) {
    f.bytes().split_at(SLOT as usize)
}

fn reboot(f: &HeapFlash) -> Option<Slot> {
    let (a, b) = slots(f);
    select_boot_slot(a, b)
}

const N_IN: usize = 12;

/// dz = intercept + sum 0.5 Ti over 12 inputs (a ~250-byte blob, four
/// chunks): the intercept tells models apart.
fn raw_model(intercept: f64) -> Model {
    let names = [
        "T1", "T2", "T3", "T4", "T5", "T6", "T7", "T8", "T9", "T10", "T11", "T12",
    ];
    let inputs: std::vec::Vec<Channel> = names
        .iter()
        .map(|n| Channel {
            name: name(n),
            reference: Reference::Absolute,
        })
        .collect();
    let coef: std::vec::Vec<Coef> = (0..N_IN as u8)
        .map(|channel| Coef {
            channel,
            value: 0.5,
        })
        .collect();
    Model {
        inputs: vec(&inputs),
        outputs: vec(&[name("dz_um")]),
        dt_s: 0.0,
        params: Params::Linear(Linear {
            outputs: vec(&[LinearOutput {
                output: 0,
                intercept,
                coef: vec(&coef),
                position: None,
            }]),
        }),
        bounds: None,
        five_point: None,
    }
}

fn model(intercept: f64) -> ValidModel {
    raw_model(intercept).validate().unwrap()
}

fn blob(intercept: f64) -> std::vec::Vec<u8> {
    crate::test_util::blob(&model(intercept))
}

/// Re-seals a blob's CRC after editing it (a blob that is well-formed but
/// wrong in content).
fn reseal(b: &mut [u8]) {
    let n = b.len() - 4;
    let crc = crc32(&b[..n]);
    b[n..].copy_from_slice(&crc.to_le_bytes());
}

/// Uploads `bytes` in chunks of `chunk` bytes, announcing their true CRC.
fn upload(
    u: &mut Uploader<HeapFlash>,
    bytes: &[u8],
    chunk: usize,
) -> Result<Committed, UploadError> {
    u.begin(bytes.len() as u32, crc32(bytes))?;
    for (i, c) in bytes.chunks(chunk).enumerate() {
        u.chunk((i * chunk) as u32, c)?;
    }
    u.commit()
}

fn intercept_of(hub: &Hub) -> f64 {
    let mut h = hub.clone();
    h.on_sample(&[0.0; N_IN]).values[0]
}

#[test]
fn record_round_trip_and_torn_record() {
    let r = CommitRecord {
        generation: 7,
        blob_crc: 0xDEAD_BEEF,
    };
    let b = r.to_bytes();
    assert_eq!(&b[..12], b"TCMC\x07\x00\x00\x00\xEF\xBE\xAD\xDE");
    assert_eq!(CommitRecord::parse(&b), Some(r));
    assert_eq!(CommitRecord::parse(&[0xFF; RECORD_LEN]), None);
    for cut in 0..RECORD_LEN {
        let mut torn = [0xFF; RECORD_LEN];
        torn[..cut].copy_from_slice(&b[..cut]);
        assert_eq!(CommitRecord::parse(&torn), None, "cut at {cut}");
    }
}

#[test]
fn board_slot_map_is_the_layout() {
    assert_eq!(
        SlotMap::BOARD,
        SlotMap {
            a: 0x4_0000,
            b: 0x6_0000,
            len: SLOT
        }
    );
}

#[test]
fn good_uploads_alternate_slots_with_rising_generations() {
    let mut u = Uploader::new(flash(), MAP, None);
    assert_eq!(reboot(&u.flash), None);
    assert_eq!(u.target(), Slot::A);

    let c = upload(&mut u, &blob(1.0), CHUNK_MAX).unwrap();
    assert_eq!((c.slot, c.generation), (Slot::A, 1));
    assert_eq!(intercept_of(&Hub::load(u.slot_bytes(c.slot))), 1.0);
    assert_eq!(reboot(&u.flash), Some(Slot::A));
    assert!(!u.is_uploading());

    // Odd chunk size (multiple of the 4-byte write size) and a padded tail.
    let c = upload(&mut u, &blob(2.0), 20).unwrap();
    assert_eq!((c.slot, c.generation), (Slot::B, 2));
    assert_eq!(reboot(&u.flash), Some(Slot::B));
    let (a, b) = slots(&u.flash);
    assert_eq!(intercept_of(&Hub::load(b)), 2.0);
    assert_eq!(intercept_of(&Hub::load(a)), 1.0);

    let c = upload(&mut u, &blob(3.0), CHUNK_MAX).unwrap();
    assert_eq!((c.slot, c.generation), (Slot::A, 3));
    assert_eq!(reboot(&u.flash), Some(Slot::A));
    assert_eq!(slot_generation(Slot::A, slots(&u.flash).0), Some(3));
    assert_eq!(slot_generation(Slot::B, slots(&u.flash).1), Some(2));
}

#[test]
fn bare_blob_in_a_boots_as_generation_zero() {
    let mut f = flash();
    let b = blob(5.0);
    f.bytes_mut()[..b.len()].copy_from_slice(&b);
    assert_eq!(reboot(&f), Some(Slot::A));
    assert_eq!(slot_generation(Slot::A, slots(&f).0), Some(0));
    // The same bare blob in B does not boot (an unfinished upload looks so).
    let mut g = flash();
    g.bytes_mut()[SLOT as usize..SLOT as usize + b.len()].copy_from_slice(&b);
    assert_eq!(reboot(&g), None);

    let mut u = Uploader::new(f, MAP, reboot(&g).or(Some(Slot::A)));
    let c = upload(&mut u, &blob(6.0), CHUNK_MAX).unwrap();
    assert_eq!((c.slot, c.generation), (Slot::B, 1));
    assert_eq!(reboot(&u.flash), Some(Slot::B));
}

/// Uploads a bad blob over a running slot A and checks the refusal and
/// that A still boots, untouched.
fn refused(bytes: &[u8]) -> UploadError {
    let mut u = Uploader::new(flash(), MAP, None);
    upload(&mut u, &blob(1.0), CHUNK_MAX).unwrap();
    let before = slots(&u.flash).0.to_vec();
    let err = upload(&mut u, bytes, CHUNK_MAX).unwrap_err();
    assert_eq!(u.active(), Some(Slot::A));
    assert!(!u.is_uploading());
    assert_eq!(reboot(&u.flash), Some(Slot::A));
    assert_eq!(slots(&u.flash).0, &before[..]);
    err
}

#[test]
fn corrupted_blobs_are_refused_and_the_old_slot_stays_active() {
    // Damaged in transit or by the host: the blob's own CRC fails.
    let mut b = blob(2.0);
    b[20] ^= 0x10;
    assert!(matches!(
        refused(&b),
        UploadError::Blob(BlobError::BadCrc { .. })
    ));

    // Another format version.
    let mut b = blob(2.0);
    b[4] = 4;
    reseal(&mut b);
    assert_eq!(
        refused(&b),
        UploadError::Blob(BlobError::UnsupportedVersion { found: 4 })
    );

    // Header kind says PCR, body is linear.
    let mut b = blob(2.0);
    b[6] = 3;
    reseal(&mut b);
    assert_eq!(
        refused(&b),
        UploadError::Blob(BlobError::BadKind { code: 3 })
    );

    // Well-formed but invalid model (non-finite coefficient).
    let b = crate::test_util::unvalidated_blob(&raw_model(f64::NAN));
    assert!(matches!(
        refused(&b),
        UploadError::Blob(BlobError::Invalid(_))
    ));

    // Not a blob at all; and a blob with bytes after it.
    let mut junk = blob(2.0);
    junk[..4].copy_from_slice(b"JUNK");
    assert_eq!(refused(&junk), UploadError::Blob(BlobError::BadMagic));
    let mut long = blob(2.0);
    long.extend([0xAB; 8]);
    assert!(matches!(
        refused(&long),
        UploadError::Blob(BlobError::LengthMismatch { .. })
    ));
}

#[test]
fn transfer_crc_mismatch_is_refused() {
    let mut u = Uploader::new(flash(), MAP, None);
    let b = blob(1.0);
    u.begin(b.len() as u32, crc32(&b) ^ 1).unwrap();
    for (i, c) in b.chunks(CHUNK_MAX).enumerate() {
        u.chunk((i * CHUNK_MAX) as u32, c).unwrap();
    }
    assert!(matches!(u.commit(), Err(UploadError::CrcMismatch { .. })));
    assert_eq!(reboot(&u.flash), None);
}

#[test]
fn interrupted_upload_is_ignored_at_reboot() {
    let mut u = Uploader::new(flash(), MAP, None);
    upload(&mut u, &blob(1.0), CHUNK_MAX).unwrap();
    // Half the chunks, then power is lost (no commit).
    let b = blob(2.0);
    u.begin(b.len() as u32, crc32(&b)).unwrap();
    u.chunk(0, &b[..CHUNK_MAX]).unwrap();
    assert!(u.is_uploading());
    let f = u.into_inner();
    assert_eq!(reboot(&f), Some(Slot::A));
    // The held-back magic: slot B holds no blob yet.
    assert_eq!(&f.bytes()[SLOT as usize..SLOT as usize + 4], &[0xFF; 4]);

    // Every byte written, blob valid, but no record: still A.
    let mut u = Uploader::new(f, MAP, Some(Slot::A));
    u.begin(b.len() as u32, crc32(&b)).unwrap();
    for (i, c) in b.chunks(CHUNK_MAX).enumerate() {
        u.chunk((i * CHUNK_MAX) as u32, c).unwrap();
    }
    assert_eq!(reboot(&u.flash), Some(Slot::A));

    // Power cut during the record write, at every byte.
    for cut in 0..RECORD_LEN {
        let mut u = Uploader::new(flash(), MAP, None);
        upload(&mut u, &blob(1.0), CHUNK_MAX).unwrap();
        u.begin(b.len() as u32, crc32(&b)).unwrap();
        for (i, c) in b.chunks(CHUNK_MAX).enumerate() {
            u.chunk((i * CHUNK_MAX) as u32, c).unwrap();
        }
        u.flash.budget = Some(cut);
        assert!(matches!(u.commit(), Err(UploadError::Flash(_))));
        assert_eq!(reboot(&u.flash), Some(Slot::A), "cut at record byte {cut}");
        assert_eq!(u.active(), Some(Slot::A));
    }
}

#[test]
fn abort_leaves_the_running_slot() {
    let mut u = Uploader::new(flash(), MAP, None);
    upload(&mut u, &blob(1.0), CHUNK_MAX).unwrap();
    let b = blob(2.0);
    u.begin(b.len() as u32, crc32(&b)).unwrap();
    u.chunk(0, &b[..CHUNK_MAX]).unwrap();
    u.abort();
    assert_eq!(
        u.chunk(CHUNK_MAX as u32, &b[CHUNK_MAX..2 * CHUNK_MAX]),
        Err(UploadError::NotUploading)
    );
    assert!(matches!(u.commit(), Err(UploadError::NotUploading)));
    assert_eq!(reboot(&u.flash), Some(Slot::A));
    // A new begin restarts cleanly into the same slot.
    let c = upload(&mut u, &b, CHUNK_MAX).unwrap();
    assert_eq!((c.slot, c.generation), (Slot::B, 2));
}

#[test]
fn out_of_order_overlapping_and_overlong_chunks_are_refused() {
    let mut u = Uploader::new(flash(), MAP, None);
    let b = blob(1.0);
    assert!(b.len() > 2 * CHUNK_MAX, "test needs three chunks");
    let c = CHUNK_MAX as u32;
    assert_eq!(u.chunk(0, &b[..8]), Err(UploadError::NotUploading));
    u.begin(b.len() as u32, crc32(&b)).unwrap();
    // The first chunk must carry the 16-byte head.
    assert_eq!(u.chunk(0, &b[..12]), Err(UploadError::BadChunk));
    // Skipping ahead.
    assert_eq!(
        u.chunk(c, &b[CHUNK_MAX..2 * CHUNK_MAX]),
        Err(UploadError::OutOfOrder { expected: 0 })
    );
    u.chunk(0, &b[..CHUNK_MAX]).unwrap();
    // Repeated and overlapping.
    assert_eq!(
        u.chunk(0, &b[..CHUNK_MAX]),
        Err(UploadError::OutOfOrder { expected: c })
    );
    assert_eq!(
        u.chunk(c - 4, &b[CHUNK_MAX - 4..CHUNK_MAX + 4]),
        Err(UploadError::OutOfOrder { expected: c })
    );
    // Not a whole write unit, and not the last chunk.
    assert_eq!(
        u.chunk(c, &b[CHUNK_MAX..CHUNK_MAX + 3]),
        Err(UploadError::BadChunk)
    );
    assert_eq!(u.chunk(c, &[]), Err(UploadError::BadChunk));
    assert_eq!(u.chunk(c, &[0; CHUNK_MAX + 4]), Err(UploadError::BadChunk));
    assert!(matches!(u.commit(), Err(UploadError::Incomplete { received }) if received == c));
    // Still uploading after refusals; the rest goes through.
    for (i, chunk) in b.chunks(CHUNK_MAX).enumerate().skip(1) {
        u.chunk((i * CHUNK_MAX) as u32, chunk).unwrap();
    }
    // Past the announced length.
    assert_eq!(u.chunk(b.len() as u32, &[0; 4]), Err(UploadError::BadChunk));
    assert_eq!(u.commit().unwrap().generation, 1);
}

#[test]
fn writes_past_the_slot_are_refused() {
    // A small geometry: 4 KiB slots, so a 16 KiB blob cannot fit.
    let small = SlotMap {
        a: 0,
        b: 4096,
        len: 4096,
    };
    let mut u = Uploader::new(HeapFlash::new(8192), small, None);
    let max = 4096 - RECORD_LEN as u32 - 4;
    assert_eq!(u.max_len(), max);
    assert_eq!(u.begin(max + 1, 0), Err(UploadError::BadLength { max }));
    assert_eq!(u.begin(15, 0), Err(UploadError::BadLength { max }));
    // Board geometry: the blob format's 16 KiB limit.
    let mut u = Uploader::new(flash(), MAP, None);
    assert_eq!(
        u.begin(MAX_BLOB_LEN as u32 + 1, 0),
        Err(UploadError::BadLength {
            max: MAX_BLOB_LEN as u32
        })
    );
    // A slot map beyond the device.
    let mut u = Uploader::new(HeapFlash::new(4096), small, None);
    assert_eq!(u.begin(100, 0), Err(UploadError::Unsupported));
    // A chunk past the end of the announced blob never reaches the flash.
    let mut u = Uploader::new(flash(), MAP, None);
    u.begin(16, 0).unwrap();
    assert_eq!(u.chunk(0, &[0; 20]), Err(UploadError::BadChunk));
    assert_eq!(u.flash.erases, 1);
}

/// The commit checks the bytes the flash holds, not those that were sent:
/// a byte that did not take its value is a CRC mismatch
/// against the announced CRC, naming the CRC of what is really there.
#[test]
fn commit_checks_the_bytes_in_flash_not_the_bytes_sent() {
    let mut u = Uploader::new(flash(), MAP, None);
    let b = blob(1.0);
    u.begin(b.len() as u32, crc32(&b)).unwrap();
    for (i, c) in b.chunks(CHUNK_MAX).enumerate() {
        u.chunk((i * CHUNK_MAX) as u32, c).unwrap();
    }
    let at = b.len() / 2;
    u.flash.bytes_mut()[at] = !b[at];
    let mut in_flash = b.clone();
    in_flash[at] = !b[at];
    assert_eq!(
        u.commit().unwrap_err(),
        UploadError::CrcMismatch {
            expected: crc32(&b),
            computed: crc32(&in_flash),
        }
    );
    assert_eq!(reboot(&u.flash), None);
}

#[test]
fn handle_answers_commands_over_the_protocol() {
    let mut u = Uploader::new(flash(), MAP, None);
    let b = blob(4.0);
    assert!(u.handle(&Command::Ping).is_none());
    let (reply, _) = u
        .handle(&Command::UploadBegin {
            len: b.len() as u32,
            crc32: crc32(&b),
        })
        .unwrap();
    assert_eq!(
        reply,
        HubMessage::Ack(crate::protocol::CommandKind::UploadBegin)
    );
    let (reply, _) = u
        .handle(&Command::UploadChunk {
            offset: 64,
            bytes: heapless::Vec::from_slice(&b[64..128]).unwrap(),
        })
        .unwrap();
    assert_eq!(
        reply,
        HubMessage::Nack {
            command: crate::protocol::CommandKind::UploadChunk,
            error: ErrorCode::OutOfOrder { expected: 0 }
        }
    );
    for (i, c) in b.chunks(CHUNK_MAX).enumerate() {
        let cmd = Command::UploadChunk {
            offset: (i * CHUNK_MAX) as u32,
            bytes: heapless::Vec::from_slice(c).unwrap(),
        };
        assert!(matches!(u.handle(&cmd), Some((HubMessage::Ack(_), None))));
    }
    let (reply, committed) = u.handle(&Command::UploadCommit).unwrap();
    assert_eq!(
        reply,
        HubMessage::Ack(crate::protocol::CommandKind::UploadCommit)
    );
    let slot = committed.unwrap().slot;
    assert_eq!(intercept_of(&Hub::load(u.slot_bytes(slot))), 4.0);
    // Error codes on the wire for blob refusals.
    assert_eq!(
        ErrorCode::from(UploadError::Blob(BlobError::BadCrc {
            stored: 0,
            computed: 1
        })),
        ErrorCode::BadBlob { reason: 6 }
    );
}
