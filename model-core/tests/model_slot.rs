//! `ModelSlot`, the in-place loader the hub uses (blobs decoded where the
//! model lies, docs/firmware-cost.md "Stack"), held to serde's derived
//! decoder of `Model` for every kind, and reused across kinds and refusals
//! without anything of an earlier model left in it.

mod common;

use model_core::blob::{self, crc32, BlobError, HEADER_LEN, TRAILER_LEN};
use model_core::{Model, ModelSlot};

/// One model of every kind, the largest filter bank the hub takes among
/// them (32 inputs x 8 features into 4 outputs, with bounds).
fn every_kind() -> Vec<Model> {
    let taus = [0.0, 300.0, 900.0, 2700.0, 8100.0, 24300.0, 72900.0, 1e6];
    vec![
        common::tf_sp2_ambient(),
        common::tf_bank_4x4(),
        common::linear_seed002(),
        common::pcr_seed003(true),
        common::bp_3_4_2(),
        common::arma_2_1_d1(),
        common::fbank_3x2(true),
        common::fbank_sized(32, &taus, &["dx_um", "dy_um", "dz_um", "e_um"]),
    ]
}

fn blob_of(model: &Model) -> Vec<u8> {
    let valid = model.clone().validate().expect("the fixture is valid");
    let mut buf = vec![0u8; blob::MAX_BLOB_LEN];
    let n = blob::encode(&valid, &mut buf).expect("the fixture encodes");
    buf.truncate(n);
    buf
}

#[test]
fn the_slot_decodes_every_kind_as_the_derived_decoder_does() {
    for model in every_kind() {
        let b = blob_of(&model);
        let body = &b[HEADER_LEN..b.len() - TRAILER_LEN];
        let derived: Model = postcard::from_bytes(body).expect("derived decode");
        let mut slot = ModelSlot::new();
        slot.load(&b).expect("the slot loads it");
        let loaded = slot.model().expect("a model");
        assert_eq!(loaded.model(), &derived, "{:?}", model.kind());
        assert_eq!(
            loaded,
            &model.clone().validate().unwrap(),
            "{:?}",
            model.kind()
        );
        assert_eq!(blob::decode(&b).ok().as_ref(), Some(loaded));
    }
}

#[test]
fn one_slot_loads_every_kind_in_turn_with_nothing_left_over() {
    let models = every_kind();
    let mut order: Vec<usize> = (0..models.len()).collect();
    // Forward, then backward: each kind follows a larger and a smaller one
    // (the largest bank before the 3-input one, whose lists are shorter).
    order.extend((0..models.len()).rev());
    let mut slot = ModelSlot::new();
    for i in order {
        let b = blob_of(&models[i]);
        slot.load(&b).expect("loads");
        assert_eq!(
            slot.model().ok(),
            blob::decode(&b).ok().as_ref(),
            "model {i}"
        );
    }
}

#[test]
fn a_refused_blob_leaves_no_model_until_the_next_good_one() {
    assert_eq!(ModelSlot::new().model(), Err(BlobError::TooShort));
    let models = every_kind();
    let big = blob_of(&models[models.len() - 1]);
    let mut slot = ModelSlot::new();
    slot.load(&big).expect("loads");
    // A body damaged half-way, its CRC recomputed: the frame passes and
    // the body decodes partly before it is refused (an output index far
    // past the model's four, or a list longer than its capacity).
    let mut bad = big.clone();
    let mid = HEADER_LEN + (bad.len() - HEADER_LEN - TRAILER_LEN) / 2;
    bad[mid..mid + 8].fill(0xFF);
    let at = bad.len() - TRAILER_LEN;
    let crc = crc32(&bad[..at]);
    bad[at..].copy_from_slice(&crc.to_le_bytes());
    let refused = slot.load(&bad).expect_err("refused");
    assert_eq!(slot.model(), Err(refused));
    assert_eq!(
        blob::decode(&bad),
        Err(refused),
        "decode refuses it the same"
    );
    // A framing error (bad CRC) also leaves no model behind.
    slot.load(&big).expect("loads");
    let mut torn = big.clone();
    torn[HEADER_LEN] ^= 1;
    assert!(matches!(slot.load(&torn), Err(BlobError::BadCrc { .. })));
    assert!(slot.model().is_err());
    // The next good blob, of another kind, loads whole.
    let small = blob_of(&models[2]);
    slot.load(&small).expect("loads");
    assert_eq!(slot.model().ok(), blob::decode(&small).ok().as_ref());
}
