//! The blob decoder and the models it yields, fed garbage.
//!
//! The hub flashes whatever arrives over the serial link, so `decode` is the
//! one gate between a damaged or hostile byte string and the loop that moves
//! the axes. These tests hold it to the promises of `blob.rs` and `model.rs`:
//!
//! - no input makes `decode`, `RealisedTf::new` or `ValidModel::step` panic;
//! - every single-byte change of a blob is caught by the framing or the CRC
//!   (CRC-32 detects every burst of up to 32 bits), and the error names the
//!   field that was hit;
//! - a body that still frames correctly (CRC recomputed) either fails to
//!   decode or yields a model that passed validation: the decoder validates,
//!   it does not trust the encoder;
//! - truncated, padded and re-labelled blobs get the documented error;
//! - encoding is deterministic and the header bytes are frozen;
//! - `step` never writes a non-finite output, and a refused step changes
//!   neither the output buffer nor the state.
//!
//! The models, one per kind with published coefficients where a seed paper
//! prints them, are the shared fixtures of `tests/common/mod.rs`.

mod common;

use common::{
    arma_2_1_d1, bp_3_4_2, fbank_3x2, from_roots, hv, linear_seed002, name, pcr_seed003,
    tf_sp2_ambient,
};
use model_core::arma::Arma;
use model_core::blob::{self, crc32, BlobError, FORMAT_VERSION, HEADER_LEN, MAGIC, MAX_BLOB_LEN};
use model_core::bp::BpNet;
use model_core::fbank::FilterBank;
use model_core::linear::LinearOutput;
use model_core::model::{StepError, MAX_INPUT_MAGNITUDE};
use model_core::pcr::Pcr;
use model_core::position::PositionTerm;
use model_core::tf::{RealisedTf, TfEntry, TfError};
use model_core::{
    decode, Bounds, Model, ModelError, ModelKind, ModelState, Params, Reference, ValidModel,
};
use proptest::prelude::*;

// ---------------------------------------------------------------------------
// Models
// ---------------------------------------------------------------------------

/// One model of each kind (and PCR with and without the position term, so
/// both arms of the `Option` are on the wire).
fn models() -> Vec<(&'static str, Model)> {
    vec![
        ("tf", tf_sp2_ambient()),
        ("linear", linear_seed002()),
        ("pcr", pcr_seed003(false)),
        ("pcr+position", pcr_seed003(true)),
        ("bp", bp_3_4_2()),
        ("arma", arma_2_1_d1()),
        ("fbank", fbank_3x2(false)),
        ("fbank+bounds", fbank_3x2(true)),
    ]
}

fn valid(model: Model) -> ValidModel {
    model.validate().expect("test model is valid")
}

/// Plausible raw inputs for a model (temperatures in C, a position in mm).
fn nominal_inputs(model: &ValidModel) -> Vec<f64> {
    (0..model.inputs().len())
        .map(|i| 21.0 + 0.5 * i as f64)
        .collect()
}

// ---------------------------------------------------------------------------
// Blob helpers
// ---------------------------------------------------------------------------

/// Encodes into a stack buffer of the largest blob size (no `alloc` needed).
fn blob_of(model: &ValidModel) -> Vec<u8> {
    let mut buf = [0u8; MAX_BLOB_LEN];
    let n = blob::encode(model, &mut buf).expect("encodes");
    buf[..n].to_vec()
}

/// The postcard body of any `Model`, valid or not.
fn body_of(model: &Model) -> Vec<u8> {
    let mut buf = [0u8; MAX_BLOB_LEN];
    postcard::to_slice(model, &mut buf)
        .expect("serialises")
        .to_vec()
}

/// Frames a body by hand, exactly as docs/blob-format.md describes it.
fn frame(kind_code: u8, body: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_LEN + body.len() + 4);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.push(kind_code);
    out.push(0);
    out.extend_from_slice(&u32::try_from(body.len()).unwrap().to_le_bytes());
    out.extend_from_slice(body);
    let crc = crc32(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// A blob of an unvalidated model: how a buggy or hostile encoder would write it.
fn blob_of_unchecked(model: &Model) -> Vec<u8> {
    frame(model.kind().code(), &body_of(model))
}

/// Rewrites the trailing CRC after the bytes before it were edited.
fn fix_crc(blob: &mut [u8]) {
    let at = blob.len() - 4;
    let crc = crc32(&blob[..at]);
    blob[at..].copy_from_slice(&crc.to_le_bytes());
}

fn stored_crc(blob: &[u8]) -> u32 {
    u32::from_le_bytes(blob[blob.len() - 4..].try_into().unwrap())
}

/// Checks what a successful decode of damaged bytes must still guarantee:
/// the model validates again (decode did validate it), it re-encodes to a
/// blob that decodes to the same model, and one step does not panic and
/// emits only finite values.
fn check_decoded(vm: &ValidModel) {
    let again = vm.model().clone().validate().expect("decoded => valid");
    let reblob = blob_of(&again);
    let back = decode(&reblob).expect("a re-encoded valid model decodes");
    assert_eq!(back.model(), vm.model());
    let x = nominal_inputs(vm);
    let mut out = [f64::NAN; 4];
    let mut state = ModelState::new();
    if vm.step(&mut state, &x, &mut out).is_ok() {
        assert!(out[..vm.outputs().len()].iter().all(|v| v.is_finite()));
    }
}

// ---------------------------------------------------------------------------
// Arbitrary bytes
// ---------------------------------------------------------------------------

proptest! {
    /// Uniform random bytes: refused by the framing checks, in the documented
    /// order (length, then magic). A random string passes the 4-byte magic
    /// with probability 2^-32 and the CRC with another 2^-32, so "practically
    /// always Err" is asserted as "Err": a failure here would be a bug, not luck.
    #[test]
    fn arbitrary_bytes_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..20_000)) {
        let e = decode(&bytes).expect_err("random bytes are no blob");
        if bytes.len() > MAX_BLOB_LEN {
            prop_assert_eq!(e, BlobError::TooLong);
        } else if bytes.len() < HEADER_LEN + 4 {
            prop_assert_eq!(e, BlobError::TooShort);
        } else if bytes[..4] != MAGIC {
            prop_assert_eq!(e, BlobError::BadMagic);
        }
    }

    /// Random bodies in a correct frame (right magic, version, length and
    /// CRC, any kind code), so the garbage reaches postcard and validation.
    #[test]
    fn framed_random_bodies_never_panic(
        kind_code in 0u8..=7,
        body in proptest::collection::vec(any::<u8>(), 0..4096),
    ) {
        match decode(&frame(kind_code, &body)) {
            Ok(vm) => check_decoded(&vm),
            Err(e) => prop_assert!(
                matches!(e, BlobError::BadKind { .. } | BlobError::Malformed | BlobError::Invalid(_)),
                "framing passed, yet {:?}", e
            ),
        }
    }

    /// Several random byte edits in a valid body, CRC recomputed: deep into
    /// postcard and validation with mostly well-formed structure.
    #[test]
    fn edited_bodies_with_fixed_crc_never_panic(
        which in 0usize..8,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
    ) {
        let (_, model) = models().swap_remove(which);
        let mut blob = blob_of(&valid(model));
        let body_len = blob.len() - HEADER_LEN - 4;
        for (at, value) in edits {
            blob[HEADER_LEN + at.index(body_len)] = value;
        }
        fix_crc(&mut blob);
        match decode(&blob) {
            Ok(vm) => check_decoded(&vm),
            Err(e) => prop_assert!(
                matches!(e, BlobError::BadKind { .. } | BlobError::Malformed | BlobError::Invalid(_)),
                "framing passed, yet {:?}", e
            ),
        }
    }
}

// ---------------------------------------------------------------------------
// Damaged valid blobs
// ---------------------------------------------------------------------------

/// Every position, every non-zero XOR mask: the error names the field hit.
/// Fields before the CRC check (magic, version, length) report themselves;
/// everything else, the kind and reserved bytes included, is a CRC mismatch
/// whose `stored` and `computed` values are exactly the two CRCs involved.
#[test]
fn every_single_byte_change_is_caught_by_framing_or_crc() {
    for (label, model) in models() {
        let good = blob_of(&valid(model));
        let n = good.len();
        let body_len = u32::try_from(n - HEADER_LEN - 4).unwrap();
        let crc = stored_crc(&good);
        for at in 0..n {
            for mask in 1..=255u8 {
                let mut bad = good.clone();
                bad[at] ^= mask;
                let e = decode(&bad).expect_err("a changed byte is caught");
                let expected = match at {
                    0..4 => BlobError::BadMagic,
                    // A flip to the other readable version passes the
                    // version check and is caught by the CRC.
                    4..6 if matches!(u16::from_le_bytes([bad[4], bad[5]]), 1..=3) => {
                        BlobError::BadCrc {
                            stored: crc,
                            computed: crc32(&bad[..n - 4]),
                        }
                    }
                    4..6 => BlobError::UnsupportedVersion {
                        found: u16::from_le_bytes([bad[4], bad[5]]),
                    },
                    8..12 => BlobError::LengthMismatch {
                        declared: u32::from_le_bytes(bad[8..12].try_into().unwrap()),
                        actual: body_len,
                    },
                    _ if at >= n - 4 => BlobError::BadCrc {
                        stored: stored_crc(&bad),
                        computed: crc,
                    },
                    _ => BlobError::BadCrc {
                        stored: crc,
                        computed: crc32(&bad[..n - 4]),
                    },
                };
                assert_eq!(e, expected, "{label}: byte {at} ^ {mask:#04x}");
            }
        }
    }
}

/// Every body byte, every XOR mask, CRC recomputed so the framing passes:
/// the body decoder and validation are on their own. Either a typed body
/// error, or a model that is valid in every respect ([`check_decoded`]).
#[test]
fn body_change_with_fixed_crc_is_refused_or_revalidates() {
    for (label, model) in models() {
        let good = blob_of(&valid(model));
        let (mut refused, mut accepted) = (0usize, 0usize);
        for at in HEADER_LEN..good.len() - 4 {
            for mask in 1..=255u8 {
                let mut bad = good.clone();
                bad[at] ^= mask;
                fix_crc(&mut bad);
                match decode(&bad) {
                    Ok(vm) => {
                        check_decoded(&vm);
                        accepted += 1;
                    }
                    Err(e) => {
                        assert!(
                            matches!(
                                e,
                                BlobError::BadKind { .. }
                                    | BlobError::Malformed
                                    | BlobError::Invalid(_)
                            ),
                            "{label}: byte {at} ^ {mask:#04x}: {e:?}"
                        );
                        refused += 1;
                    }
                }
            }
        }
        // Both happen: a changed coefficient is still a model (the CRC, not
        // validation, is what catches that), a changed tag or length is not.
        assert!(
            refused > 0 && accepted > 0,
            "{label}: {refused} / {accepted}"
        );
    }
}

/// Cut short at every length: too short for a frame, or a body shorter than
/// the header says. With the header and CRC patched to match the shorter
/// body, postcard runs out of bytes: `Malformed`.
#[test]
fn truncation_at_every_length_is_refused() {
    for (label, model) in models() {
        let good = blob_of(&valid(model));
        let declared = u32::from_le_bytes(good[8..12].try_into().unwrap());
        for len in 0..good.len() {
            let e = decode(&good[..len]).expect_err("truncated");
            if len < HEADER_LEN + 4 {
                assert_eq!(e, BlobError::TooShort, "{label}: {len} bytes");
            } else {
                let actual = u32::try_from(len - HEADER_LEN - 4).unwrap();
                assert_eq!(
                    e,
                    BlobError::LengthMismatch { declared, actual },
                    "{label}: {len} bytes"
                );
            }
        }
        let body = &good[HEADER_LEN..good.len() - 4];
        for cut in 0..body.len() {
            let e = decode(&frame(good[6], &body[..cut])).expect_err("short body");
            assert_eq!(e, BlobError::Malformed, "{label}: body cut to {cut}");
        }
    }
}

/// Padded: the length no longer agrees; with the header and CRC patched,
/// postcard reports the trailing bytes; past 16 KiB, `TooLong` first.
#[test]
fn appended_bytes_are_refused() {
    for (label, model) in models() {
        let good = blob_of(&valid(model));
        let declared = u32::from_le_bytes(good[8..12].try_into().unwrap());
        let body = &good[HEADER_LEN..good.len() - 4];
        for extra in [1usize, 2, 3, 4, 7, 64, 1000] {
            for fill in [0x00u8, 0xFF] {
                let mut long = good.clone();
                long.resize(good.len() + extra, fill);
                let actual = declared + u32::try_from(extra).unwrap();
                assert_eq!(
                    decode(&long).unwrap_err(),
                    BlobError::LengthMismatch { declared, actual },
                    "{label}: +{extra} x {fill:#04x}"
                );
                let mut padded_body = body.to_vec();
                padded_body.resize(body.len() + extra, fill);
                assert_eq!(
                    decode(&frame(good[6], &padded_body)).unwrap_err(),
                    BlobError::Malformed,
                    "{label}: body +{extra} x {fill:#04x}"
                );
            }
        }
        let mut huge = good.clone();
        huge.resize(MAX_BLOB_LEN + 1, 0);
        assert_eq!(decode(&huge).unwrap_err(), BlobError::TooLong, "{label}");
    }
}

/// Each header field changed on its own, with the CRC recomputed so that
/// only that field is wrong.
#[test]
fn header_fields_are_checked() {
    for (label, model) in models() {
        let good = blob_of(&valid(model));
        let kind = good[6];

        for magic in [*b"TCMA", *b"tcmb", [0; 4], [0xFF; 4], *b"BMCT"] {
            let mut bad = good.clone();
            bad[..4].copy_from_slice(&magic);
            fix_crc(&mut bad);
            assert_eq!(decode(&bad).unwrap_err(), BlobError::BadMagic, "{label}");
        }

        for version in [0u16, 4, 0x0100, u16::MAX] {
            let mut bad = good.clone();
            bad[4..6].copy_from_slice(&version.to_le_bytes());
            fix_crc(&mut bad);
            assert_eq!(
                decode(&bad).unwrap_err(),
                BlobError::UnsupportedVersion { found: version },
                "{label}"
            );
        }

        // Unknown codes and known codes that disagree with the body alike.
        for code in (0..=255u8).filter(|c| *c != kind) {
            let mut bad = good.clone();
            bad[6] = code;
            fix_crc(&mut bad);
            assert_eq!(
                decode(&bad).unwrap_err(),
                BlobError::BadKind { code },
                "{label}: code {code}"
            );
        }

        let actual = u32::try_from(good.len() - HEADER_LEN - 4).unwrap();
        for declared in [0, actual - 1, actual + 1, actual + 4, 1 << 16, u32::MAX] {
            let mut bad = good.clone();
            bad[8..12].copy_from_slice(&declared.to_le_bytes());
            fix_crc(&mut bad);
            assert_eq!(
                decode(&bad).unwrap_err(),
                BlobError::LengthMismatch { declared, actual },
                "{label}: declared {declared}"
            );
        }

        // A version-2 body relabelled as version 1 has one byte too many
        // (the bounds field, which version 1 lacks).
        let mut old = good.clone();
        old[4..6].copy_from_slice(&1u16.to_le_bytes());
        fix_crc(&mut old);
        assert_eq!(decode(&old).unwrap_err(), BlobError::Malformed, "{label}");

        // The reserved byte is covered by the CRC but not interpreted
        // (room for flags in a later version 1.x writer).
        let mut reserved = good.clone();
        reserved[7] = 0xA5;
        fix_crc(&mut reserved);
        assert!(decode(&reserved).is_ok(), "{label}: reserved byte");
    }
}

// ---------------------------------------------------------------------------
// Round trips and frozen bytes
// ---------------------------------------------------------------------------

/// encode -> decode -> encode gives the same bytes, the same model, and the
/// same bytes as the by-hand framing of the postcard body.
#[test]
fn round_trip_is_byte_exact_for_every_kind() {
    let kinds = [
        ModelKind::Tf,
        ModelKind::Linear,
        ModelKind::Pcr,
        ModelKind::Pcr,
        ModelKind::Bp,
        ModelKind::Arma,
        ModelKind::Fbank,
        ModelKind::Fbank,
    ];
    for ((label, model), kind) in models().into_iter().zip(kinds) {
        let vm = valid(model.clone());
        let first = blob_of(&vm);
        let back = decode(&first).expect("decodes");
        assert_eq!(back.model(), &model, "{label}");
        assert_eq!(back.kind(), kind, "{label}");
        assert_eq!(blob_of(&back), first, "{label}: re-encoding");
        assert_eq!(blob_of_unchecked(&model), first, "{label}: hand framing");
        assert_eq!(first[6], kind.code(), "{label}");
        assert!(first.len() < 1024, "{label}: {} bytes", first.len());
    }
}

/// The header of `examples/seed004_sp2_ambient.toml`'s blob, byte for byte.
///
/// Body length by hand (postcard: varint lengths and enum tags, u8 raw,
/// f64 as 8 bytes LE): inputs 1 + ("T1": 1+2, First: 1) + ("ambient_c":
/// 1+9, First: 1) = 16; outputs 1 + ("dz_um": 1+5) = 7; dt_s 8; params:
/// tag 1 + count 1 + SP2 (1+1 + a 1+3*8 + b 1+2*8 = 44) + ambient (1+1 +
/// 1+3*8 + 1+3*8 = 52) = 98; bounds `None` 1 (format version 2);
/// five-point geometry `None` 1 (format version 3). Total 131 = 0x83.
#[test]
fn sp2_ambient_header_bytes_are_frozen() {
    let blob = blob_of(&valid(tf_sp2_ambient()));
    assert_eq!(
        blob[..HEADER_LEN],
        [b'T', b'C', b'M', b'B', 3, 0, 1, 0, 0x83, 0, 0, 0]
    );
    assert_eq!(blob.len(), HEADER_LEN + 131 + 4);
    assert_eq!(
        blob[blob.len() - 6..blob.len() - 4],
        [0, 0],
        "bounds: None, then five_point: None, end the body"
    );
    let crc_at = blob.len() - 4;
    assert_eq!(stored_crc(&blob), crc32(&blob[..crc_at]));
    // dt_s = 1.0 follows the inputs (16 bytes) and outputs (7 bytes).
    let dt_at = HEADER_LEN + 16 + 7;
    assert_eq!(blob[dt_at..dt_at + 8], 1.0f64.to_le_bytes());
    // SP2's a0 = 16.0005 follows the params tag, entry count, output, input
    // and the length of `a`.
    let a0_at = dt_at + 8 + 1 + 1 + 1 + 1 + 1;
    assert_eq!(blob[a0_at..a0_at + 8], 16.0005f64.to_le_bytes());
}

// ---------------------------------------------------------------------------
// Invalid models: refused by validate, and by decode when written by hand
// ---------------------------------------------------------------------------

/// `validate` refuses the model with `expected`, and a blob of that model
/// framed by hand (correct CRC, so only validation can catch it) is refused
/// by `decode` with `Invalid(expected)`.
fn refused_both_ways(label: &str, model: Model, expected: ModelError) {
    let blob = blob_of_unchecked(&model);
    assert_eq!(model.validate().unwrap_err(), expected, "{label}: validate");
    assert_eq!(
        decode(&blob).unwrap_err(),
        BlobError::Invalid(expected),
        "{label}: decode"
    );
}

fn with_tf(f: impl FnOnce(&mut heapless::Vec<TfEntry, 16>)) -> Model {
    let mut m = tf_sp2_ambient();
    let Params::Tf(entries) = &mut m.params else {
        unreachable!()
    };
    f(entries);
    m
}

fn with_linear(f: impl FnOnce(&mut LinearOutput)) -> Model {
    let mut m = linear_seed002();
    let Params::Linear(lin) = &mut m.params else {
        unreachable!()
    };
    f(&mut lin.outputs[0]);
    m
}

fn with_pcr(f: impl FnOnce(&mut Pcr)) -> Model {
    let mut m = pcr_seed003(true);
    let Params::Pcr(pcr) = &mut m.params else {
        unreachable!()
    };
    f(pcr);
    m
}

fn with_bp(f: impl FnOnce(&mut BpNet)) -> Model {
    let mut m = bp_3_4_2();
    let Params::Bp(net) = &mut m.params else {
        unreachable!()
    };
    f(net);
    m
}

fn with_arma(f: impl FnOnce(&mut Arma)) -> Model {
    let mut m = arma_2_1_d1();
    let Params::Arma(a) = &mut m.params else {
        unreachable!()
    };
    f(a);
    m
}

/// A number no model needs: just beyond `capacity::MAX_MAGNITUDE` (1e12), on
/// either side, and the 1e300 a hand-made blob carried (it decoded, and its
/// products overflow to infinity).
const ABSURD: [f64; 3] = [1.000_001e12, -1.000_001e12, 1e300];

#[test]
fn non_finite_coefficients_are_refused() {
    use ModelError::NonFinite;
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY]
        .into_iter()
        .chain(ABSURD)
    {
        let cases: Vec<(&str, Model)> = vec![
            ("tf a", with_tf(|e| e[0].a[1] = bad)),
            ("tf b", with_tf(|e| e[1].b[2] = bad)),
            ("linear intercept", with_linear(|o| o.intercept = bad)),
            ("linear coef", with_linear(|o| o.coef[3].value = bad)),
            (
                "linear position",
                with_linear(|o| {
                    o.position = Some(PositionTerm {
                        channel: 0,
                        poly: hv(&[0.0, bad]),
                        k0: 0.0,
                    })
                }),
            ),
            ("pcr beta", with_pcr(|o| o.outputs[0].beta[0] = bad)),
            ("pcr intercept", with_pcr(|o| o.outputs[0].intercept = bad)),
            ("pcr weight", with_pcr(|o| o.components[0].weights[4] = bad)),
            (
                "pcr component intercept",
                with_pcr(|o| o.components[0].intercept = bad),
            ),
            (
                "pcr position k0",
                with_pcr(|o| o.outputs[0].position.as_mut().unwrap().k0 = bad),
            ),
            ("bp w1", with_bp(|n| n.w1[7] = bad)),
            ("bp b1", with_bp(|n| n.b1[0] = bad)),
            ("bp w2", with_bp(|n| n.w2[7] = bad)),
            ("bp b2", with_bp(|n| n.b2[1] = bad)),
            ("reference value", {
                let mut m = linear_seed002();
                m.inputs[2].reference = Reference::Value(bad);
                m
            }),
        ];
        for (label, model) in cases {
            refused_both_ways(&format!("{label} = {bad}"), model, NonFinite);
        }
        // ARMA coefficients are checked for finiteness like every other kind.
        for (label, model) in [
            ("arma phi", with_arma(|a| a.phi[1] = bad)),
            ("arma theta", with_arma(|a| a.theta[0] = bad)),
            ("arma mean", with_arma(|a| a.mean = bad)),
            ("arma std", with_arma(|a| a.std = bad)),
            ("arma constant", with_arma(|a| a.constant = bad)),
        ] {
            refused_both_ways(&format!("{label} = {bad}"), model, NonFinite);
        }
        if bad.is_finite() {
            continue;
        }
        // A dynamic model's sample time.
        refused_both_ways(
            &format!("dt_s = {bad}"),
            {
                let mut m = tf_sp2_ambient();
                m.dt_s = bad;
                m
            },
            ModelError::BadSampleTime,
        );
    }
    // The mapminmax scales: infinite or NaN, both are NonFinite (finiteness is
    // checked before the `x_min <= x_max` ordering, which NaN would fail).
    refused_both_ways(
        "bp x_min = -inf",
        with_bp(|n| n.x_min[0] = f64::NEG_INFINITY),
        NonFinite,
    );
    refused_both_ways(
        "bp y_max = inf",
        with_bp(|n| n.y_max[1] = f64::INFINITY),
        NonFinite,
    );
    refused_both_ways(
        "bp x_max = NaN",
        with_bp(|n| n.x_max[2] = f64::NAN),
        NonFinite,
    );
    refused_both_ways(
        "bp x_min = -1e300",
        with_bp(|n| n.x_min[0] = -1e300),
        NonFinite,
    );
    // What runs is bounded too: a TF's coefficients over a tiny b0, a BP
    // input's mapminmax gain over a tiny span.
    refused_both_ways(
        "tf a / b0 = 1e302",
        with_tf(|e| {
            e[0].a = hv(&[1e12]);
            e[0].b = hv(&[1e-290]);
        }),
        NonFinite,
    );
    refused_both_ways(
        "bp x span 1e-300",
        with_bp(|n| {
            n.x_min[0] = 0.0;
            n.x_max[0] = 1e-300;
        }),
        NonFinite,
    );
    // The bound itself is a number a model may hold.
    let at_bound = with_linear(|o| o.coef[3].value = model_core::capacity::MAX_MAGNITUDE);
    assert!(at_bound.validate().is_ok());
}

/// Seed 004's printed example of what validation must stop: a pole at 1.2
/// (diverges) and a bare integrator (pole at 1, no zero to cancel it).
/// Put in entry 1 of the bank, so the error also names the right entry.
#[test]
fn unstable_and_marginal_tfs_are_refused() {
    let unstable = with_tf(|e| {
        e[1].b = hv(&[1.0, -1.2]);
    });
    let err = unstable.clone().validate().unwrap_err();
    let ModelError::Tf {
        entry: 1,
        error: TfError::Unstable { re, im },
    } = err
    else {
        panic!("expected Unstable in entry 1, got {err:?}")
    };
    // A first-order denominator: the pole is exactly -b1/b0 = 1.2 up to
    // the root finder's rounding (1e-12).
    assert!((re - 1.2).abs() < 1e-12 && im.abs() < 1e-12, "{re} {im}");
    refused_both_ways("unstable", unstable, err);

    let marginal = with_tf(|e| {
        e[1].a = hv(&[0.1]);
        e[1].b = hv(&[1.0, -1.0]);
    });
    let err = marginal.clone().validate().unwrap_err();
    let ModelError::Tf {
        entry: 1,
        error: TfError::MarginallyStable { re, im },
    } = err
    else {
        panic!("expected MarginallyStable in entry 1, got {err:?}")
    };
    assert!((re - 1.0).abs() < 1e-12 && im.abs() < 1e-12, "{re} {im}");
    refused_both_ways("marginal", marginal, err);

    let no_b0 = with_tf(|e| e[0].b = hv(&[0.0, 1.0]));
    refused_both_ways(
        "b0 = 0",
        no_b0,
        ModelError::Tf {
            entry: 0,
            error: TfError::ZeroLeadingDenominator,
        },
    );
}

/// The structural checks of `validate`, each reached through `decode` of a
/// hand-framed blob.
#[test]
fn decoder_applies_every_structural_check() {
    use ModelError::*;
    let cases: Vec<(&str, Model, ModelError)> = vec![
        (
            "no outputs",
            {
                let mut m = linear_seed002();
                m.outputs.clear();
                m
            },
            NoInputsOrOutputs,
        ),
        (
            "no inputs",
            {
                let mut m = tf_sp2_ambient();
                m.inputs.clear();
                m
            },
            NoInputsOrOutputs,
        ),
        (
            "empty input name",
            {
                let mut m = bp_3_4_2();
                m.inputs[1].name.clear();
                m
            },
            EmptyName,
        ),
        (
            "line break in an input name",
            {
                let mut m = bp_3_4_2();
                m.inputs[1].name = name("T1\nT2");
                m
            },
            ControlInName,
        ),
        (
            "escape in an output name",
            {
                let mut m = bp_3_4_2();
                m.outputs[0] = name("dz\u{1b}[2J");
                m
            },
            ControlInName,
        ),
        (
            "duplicate output",
            {
                let mut m = bp_3_4_2();
                m.outputs[1] = name("dx_um");
                m
            },
            DuplicateName,
        ),
        (
            "tf input index",
            with_tf(|e| e[1].input = 2),
            IndexOutOfRange,
        ),
        (
            "tf output index",
            with_tf(|e| e[0].output = 1),
            IndexOutOfRange,
        ),
        (
            "linear channel",
            with_linear(|o| o.coef[0].channel = 4),
            IndexOutOfRange,
        ),
        (
            "pcr beta count",
            with_pcr(|o| {
                o.outputs[0].beta.push(0.5).unwrap();
            }),
            ShapeMismatch,
        ),
        (
            "pcr weight count",
            with_pcr(|o| {
                o.components[0].weights.pop();
            }),
            ShapeMismatch,
        ),
        (
            "pcr position channel",
            with_pcr(|o| o.outputs[0].position.as_mut().unwrap().channel = 6),
            IndexOutOfRange,
        ),
        (
            "bp w1 size",
            with_bp(|n| {
                n.w1.pop();
            }),
            ShapeMismatch,
        ),
        (
            "bp x_min > x_max",
            with_bp(|n| n.x_min[0] = 50.0),
            ShapeMismatch,
        ),
        (
            // Output 1 is also unused, but the repeat is the mistake.
            "bp output twice",
            with_bp(|n| {
                n.outputs[1] = 0;
            }),
            DuplicateOutput { output: 0 },
        ),
        (
            "bp unused output",
            // The net computes dx_um only; the model also names dz_um.
            with_bp(|n| {
                n.outputs.pop();
                n.w2.truncate(4);
                n.b2.truncate(1);
                n.y_min.truncate(1);
                n.y_max.truncate(1);
            }),
            OutputUnused { output: 1 },
        ),
        ("arma std 0", with_arma(|a| a.std = 0.0), BadArma),
        ("arma diff 3", with_arma(|a| a.diff = 3), BadArma),
        (
            "arma on a relative channel",
            {
                let mut m = arma_2_1_d1();
                m.inputs[0].reference = Reference::First;
                m
            },
            BadArma,
        ),
        (
            "tf without dt",
            {
                let mut m = tf_sp2_ambient();
                m.dt_s = 0.0;
                m
            },
            BadSampleTime,
        ),
        (
            "negative dt",
            {
                let mut m = linear_seed002();
                m.dt_s = -1.0;
                m
            },
            BadSampleTime,
        ),
    ];
    for (label, model, expected) in cases {
        refused_both_ways(label, model, expected);
    }
}

fn with_fbank(f: impl FnOnce(&mut FilterBank)) -> Model {
    let mut m = fbank_3x2(false);
    let Params::Fbank(bank) = &mut m.params else {
        unreachable!()
    };
    f(bank);
    m
}

fn with_bounds(f: impl FnOnce(&mut Bounds)) -> Model {
    let mut m = fbank_3x2(true);
    f(m.bounds.as_mut().unwrap());
    m
}

/// Every refusal of a filter bank and of calibration bounds, each reached
/// through `decode` of a hand-framed blob as well.
#[test]
fn fbank_and_bounds_refusals() {
    use ModelError::*;
    let cases: Vec<(&str, Model, ModelError)> = vec![
        (
            "power 0",
            with_fbank(|b| b.features[1].power = 0),
            BadFeature { feature: 1 },
        ),
        (
            "power 3",
            with_fbank(|b| b.features[3].power = 3),
            BadFeature { feature: 3 },
        ),
        (
            "tau < 0",
            with_fbank(|b| b.features[2].tau_s = -1.0),
            BadFeature { feature: 2 },
        ),
        (
            "tau NaN",
            with_fbank(|b| b.features[2].tau_s = f64::NAN),
            NonFinite,
        ),
        (
            "tau inf",
            with_fbank(|b| b.features[2].tau_s = f64::INFINITY),
            NonFinite,
        ),
        (
            "input index",
            with_fbank(|b| b.features[4].input = 3),
            IndexOutOfRange,
        ),
        (
            "output index",
            with_fbank(|b| b.outputs[1].output = 2),
            IndexOutOfRange,
        ),
        (
            "coef short",
            with_fbank(|b| {
                b.outputs[0].coef.pop();
            }),
            ShapeMismatch,
        ),
        (
            "coef long",
            with_fbank(|b| b.outputs[1].coef.push(1.0).unwrap()),
            ShapeMismatch,
        ),
        (
            "duplicate output",
            with_fbank(|b| b.outputs[1].output = 0),
            DuplicateOutput { output: 0 },
        ),
        (
            "coef NaN",
            with_fbank(|b| b.outputs[0].coef[2] = f64::NAN),
            NonFinite,
        ),
        (
            "intercept inf",
            with_fbank(|b| b.outputs[1].intercept = f64::NEG_INFINITY),
            NonFinite,
        ),
        (
            "unused output",
            with_fbank(|b| {
                b.outputs.pop();
            }),
            OutputUnused { output: 1 },
        ),
        (
            "fbank without dt",
            {
                let mut m = fbank_3x2(false);
                m.dt_s = 0.0;
                m
            },
            BadSampleTime,
        ),
        (
            "envelope short",
            with_bounds(|b| {
                b.envelope.pop();
            }),
            ShapeMismatch,
        ),
        (
            "half_width long",
            with_bounds(|b| b.half_width.push(1.0).unwrap()),
            ShapeMismatch,
        ),
        (
            "span NaN",
            with_bounds(|b| b.envelope[1].min = f64::NAN),
            NonFinite,
        ),
        (
            "span inf",
            with_bounds(|b| b.envelope[0].max = f64::INFINITY),
            NonFinite,
        ),
        (
            "half_width NaN",
            with_bounds(|b| b.half_width[0] = f64::NAN),
            NonFinite,
        ),
        (
            "min > max",
            with_bounds(|b| b.envelope[2].min = 5.0),
            BadBounds,
        ),
        (
            "span beyond MAX_MAGNITUDE",
            with_bounds(|b| {
                b.envelope[0].min = -f64::MAX;
                b.envelope[0].max = f64::MAX;
            }),
            NonFinite,
        ),
        (
            "half_width 1e300",
            with_bounds(|b| b.half_width[0] = 1e300),
            NonFinite,
        ),
        (
            "fbank coef 1e300",
            with_fbank(|b| b.outputs[0].coef[1] = 1e300),
            NonFinite,
        ),
        (
            "fbank tau_s 1e300 (only the hold's f64::MAX is beyond the bound)",
            with_fbank(|b| b.features[0].tau_s = 1e300),
            NonFinite,
        ),
        (
            "half_width < 0",
            with_bounds(|b| b.half_width[1] = -0.1),
            BadBounds,
        ),
        (
            "growth short",
            with_bounds(|b| {
                b.growth.pop();
            }),
            ShapeMismatch,
        ),
        (
            "growth NaN",
            with_bounds(|b| b.growth[0] = f64::NAN),
            NonFinite,
        ),
        ("growth < 0", with_bounds(|b| b.growth[1] = -1.0), BadBounds),
        (
            "bounds on a tf model, wrong shape",
            {
                let mut m = tf_sp2_ambient();
                m.bounds = fbank_3x2(true).bounds;
                m
            },
            ShapeMismatch,
        ),
    ];
    for (label, model, expected) in cases {
        refused_both_ways(label, model, expected);
    }
}

// ---------------------------------------------------------------------------
// Realising random transfer functions
// ---------------------------------------------------------------------------

/// A coefficient in [-2, 2], with exact 0 and +-1 over-represented: they
/// make trailing zeros, a zero b0, and poles or zeros on the unit circle,
/// which uniform draws never hit.
fn coeff() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => -2.0..=2.0f64,
        1 => Just(0.0),
        1 => Just(1.0),
        1 => Just(-1.0),
    ]
}

fn mul(p: &[f64], q: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; p.len() + q.len() - 1];
    for (i, a) in p.iter().enumerate() {
        for (j, b) in q.iter().enumerate() {
            out[i + j] += a * b;
        }
    }
    out
}

/// Runs `n` samples of a bounded input through a realised TF from rest,
/// returning the largest |output| (or the first non-finite one).
fn run_bounded(tf: &RealisedTf, n: usize) -> f64 {
    let mut h = tf.steady_state(0.0);
    let mut worst = 0.0_f64;
    for k in 0..n {
        // A square wave with a slow ramp: full-scale steps and a DC part,
        // |u| <= 1.
        let u = if (k / 37) % 2 == 0 { 1.0 } else { -1.0 } * (k % 1000) as f64 / 1000.0;
        let y = tf.output(&h, u);
        if !y.is_finite() {
            return y;
        }
        worst = worst.max(y.abs());
        h.push(u, y);
    }
    worst
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Random orders 0..=8 and coefficients in [-2, 2]: `RealisedTf::new`
    /// never panics; when it accepts, every pole of the realised denominator
    /// lies inside the unit circle by more than the 1e-6 band that
    /// validation treats as "on the circle", and 10,000 samples of a bounded
    /// input stay finite.
    #[test]
    fn random_tfs_realise_stably_or_are_refused(
        a in proptest::collection::vec(coeff(), 0..=9),
        b in proptest::collection::vec(coeff(), 0..=9),
    ) {
        match RealisedTf::new(&a, &b) {
            Ok(tf) => {
                prop_assert_eq!(tf.denominator().first().copied(), Some(1.0));
                let poles = model_core::poly::roots(tf.denominator()).expect("roots");
                for p in poles.as_slice() {
                    prop_assert!(p.abs() < 1.0 - 1e-6, "pole {:?} of {:?}", p, tf.denominator());
                }
                prop_assert!(tf.dc_gain().is_finite());
                let worst = run_bounded(&tf, 10_000);
                prop_assert!(worst.is_finite(), "{:?} / {:?} -> {}", a, b, worst);
            }
            Err(e) => prop_assert!(
                !matches!(e, TfError::NonFinite | TfError::OrderTooHigh),
                "finite coefficients of order <= 8 refused as {:?}", e
            ),
        }
    }

    /// Any f64 at all (NaN, infinities, subnormals, 1e308) and up to 12
    /// coefficients: never a panic; a non-finite coefficient is `NonFinite`.
    #[test]
    fn any_tf_coefficients_never_panic(
        a in proptest::collection::vec(any::<f64>(), 0..=12),
        b in proptest::collection::vec(any::<f64>(), 0..=12),
    ) {
        let r = RealisedTf::new(&a, &b);
        if a.iter().chain(&b).any(|c| !c.is_finite()) {
            prop_assert_eq!(r.unwrap_err(), TfError::NonFinite);
        }
    }

    /// A stable TF times a common `(1 - q)` factor, as published models carry
    /// it (seed 004's ambient TF): always accepted, the factor is cancelled,
    /// and the gain is that of the stable part, `A(1) / B(1)`, to 1e-9
    /// relative. The deflation is exact but for rounding, which the
    /// condition number `sum|B| / B(1) <= 1.95^4 / 0.05^4 = 2.3e6` scales to
    /// about 2.3e6 * 2.2e-16 = 5e-10.
    #[test]
    fn common_unit_factor_is_cancelled(
        zeros in proptest::collection::vec(-0.95..0.95f64, 0..=3),
        poles in proptest::collection::vec(-0.95..0.95f64, 1..=4),
        gain in prop_oneof![-2.0..-0.01f64, 0.01..2.0f64],
    ) {
        let a_stable: Vec<f64> = from_roots(&zeros).iter().map(|c| gain * c).collect();
        let b_stable = from_roots(&poles);
        let unit = [1.0, -1.0];
        let tf = RealisedTf::new(&mul(&a_stable, &unit), &mul(&b_stable, &unit))
            .expect("a cancelled unit factor leaves a stable TF");
        prop_assert!(tf.cancelled() >= 1);
        let expected = a_stable.iter().sum::<f64>() / b_stable.iter().sum::<f64>();
        prop_assert!(
            (tf.dc_gain() - expected).abs() <= 1e-9 * expected.abs(),
            "{} vs {}", tf.dc_gain(), expected
        );
    }

    /// Stable by construction, orders 1..=8: real poles and complex pairs of
    /// modulus below 0.9, any numerator. Always accepted as it is (nothing
    /// to cancel, denominator unchanged), and after 10,000 samples of a unit
    /// step the recursion has settled on `dc_gain()` (0.9^10000 is 1e-458).
    /// Tolerance: 1e-9 of `sum|a| / prod(1 - |p|)`, the bound on the impulse
    /// response's l1 norm that scales the recursion's rounding.
    #[test]
    fn stable_tfs_are_accepted_unchanged(
        factors in proptest::collection::vec((0.0..0.9f64, 0.0..std::f64::consts::PI, any::<bool>()), 1..=4),
        a in proptest::collection::vec(-2.0..2.0f64, 1..=9),
    ) {
        let mut b = vec![1.0];
        let mut bound = a.iter().map(|c| c.abs()).sum::<f64>();
        for (r, theta, pair) in &factors {
            let f = if *pair {
                bound /= (1.0 - r) * (1.0 - r);
                vec![1.0, -2.0 * r * theta.cos(), r * r]
            } else {
                bound /= 1.0 - r;
                vec![1.0, -r * theta.cos().signum()]
            };
            b = mul(&b, &f);
        }
        let tf = RealisedTf::new(&a, &b).expect("stable by construction");
        prop_assert_eq!(tf.cancelled(), 0);
        prop_assert_eq!(tf.denominator(), model_core::poly::trim(&b));
        let mut h = tf.steady_state(0.0);
        let mut y = 0.0;
        for _ in 0..10_000 {
            y = tf.output(&h, 1.0);
            h.push(1.0, y);
        }
        prop_assert!(
            (y - tf.dc_gain()).abs() <= 1e-9 * bound,
            "settled at {} vs gain {} (bound {})", y, tf.dc_gain(), bound
        );
    }
}

// ---------------------------------------------------------------------------
// Stepping valid models with hostile inputs
// ---------------------------------------------------------------------------

/// An input sample: mostly ordinary, often hostile.
fn input_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => -50.0..150.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(1e300),
        1 => Just(-1e300),
        1 => Just(f64::MAX),
        1 => Just(f64::MIN),
        1 => Just(1e-310),
        2 => any::<f64>(),
    ]
}

/// No non-finite value in a state. Its fields are private; `Debug` shows
/// every f64 in it, and prints a non-finite one as `NaN`, `inf` or `-inf`.
fn state_is_finite(state: &ModelState) -> bool {
    let s = format!("{state:?}");
    !s.contains("NaN") && !s.contains("inf")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any sequence of samples: `step` never panics and never writes a
    /// non-finite output or lets one into the state; a refused step leaves
    /// the output buffer (bit for bit) and the state as they were.
    #[test]
    fn step_never_emits_non_finite_values(
        which in 0usize..8,
        samples in proptest::collection::vec(
            proptest::collection::vec(input_value(), 6), 1..60),
    ) {
        let (label, model) = models().swap_remove(which);
        let vm = valid(model);
        let n_in = vm.inputs().len();
        let n_out = vm.outputs().len();
        let mut state = ModelState::new();
        let sentinel = f64::from_bits(0x7FF0_DEAD_BEEF_0001); // a NaN no code writes
        for sample in &samples {
            let mut out = [sentinel; 4];
            let before = state.clone();
            match vm.step(&mut state, &sample[..n_in], &mut out) {
                Ok(()) => {
                    prop_assert!(
                        out[..n_out].iter().all(|v| v.is_finite()),
                        "{}: {:?} -> {:?}", label, &sample[..n_in], out
                    );
                    prop_assert!(state.started());
                    prop_assert!(
                        state_is_finite(&state),
                        "{}: {:?} -> {:?}", label, &sample[..n_in], state
                    );
                }
                Err(e) => {
                    prop_assert!(
                        out.iter().all(|v| v.to_bits() == sentinel.to_bits()),
                        "{}: {:?} wrote {:?}", label, e, out
                    );
                    prop_assert!(state == before, "{}: {:?} changed the state", label, e);
                    // The first bad channel is named, whatever made it bad.
                    let bad = sample[..n_in]
                        .iter()
                        .position(|v| !v.is_finite() || v.abs() > MAX_INPUT_MAGNITUDE);
                    if let Some(ch) = bad {
                        let expected = if sample[ch].is_finite() {
                            StepError::InputOutOfRange { channel: ch as u8 }
                        } else {
                            StepError::NonFiniteInput { channel: ch as u8 }
                        };
                        prop_assert_eq!(e, expected);
                    }
                }
            }
        }
    }

    /// Wrong buffer sizes are refused before anything is computed.
    #[test]
    fn wrong_sizes_are_refused_without_writing(which in 0usize..8, extra in 1usize..4) {
        let (_, model) = models().swap_remove(which);
        let vm = valid(model);
        let n_in = vm.inputs().len();
        let mut state = ModelState::new();
        let x = vec![20.0; n_in + extra];
        let mut out = [7.0; 4];
        prop_assert_eq!(
            vm.step(&mut state, &x, &mut out),
            Err(StepError::InputCount { expected: n_in as u8, got: (n_in + extra) as u8 })
        );
        prop_assert_eq!(
            vm.step(&mut state, &x[..n_in - 1], &mut out),
            Err(StepError::InputCount { expected: n_in as u8, got: (n_in - 1) as u8 })
        );
        let n_out = vm.outputs().len();
        prop_assert_eq!(
            vm.step(&mut state, &x[..n_in], &mut out[..n_out - 1]),
            Err(StepError::OutputSpace)
        );
        prop_assert_eq!(out, [7.0; 4]);
        prop_assert!(!state.started());
    }
}

/// The state-finiteness half of `model.rs`'s promise ("it never lets a
/// non-finite value into its state"), after finite but extreme inputs, for
/// every kind but ARMA (see [`arma_state_stays_finite_after_extreme_input`]).
#[test]
fn state_stays_finite_after_extreme_inputs() {
    for (label, model) in models().into_iter().filter(|(l, _)| *l != "arma") {
        let vm = valid(model);
        let n_in = vm.inputs().len();
        let mut state = ModelState::new();
        let mut out = [0.0; 4];
        for v in [20.0, 21.0, 1e300, -1e300, f64::MAX, f64::MIN, 24.0] {
            let _ = vm.step(&mut state, &vec![v; n_in], &mut out);
            assert!(state_is_finite(&state), "{label}: after {v:e}: {state:?}");
        }
        // And the model still runs on ordinary samples afterwards.
        vm.step(&mut state, &vec![25.0; n_in], &mut out)
            .unwrap_or_else(|e| panic!("{label}: stuck after extreme inputs: {e:?}"));
    }
}

/// Regression test for a bug found by this file. ARMA's `observe` computed
/// `z = (y - mean) / std` and the innovation `(y - yhat) / std` unchecked,
/// and `step` checked only the outputs, so a finite but extreme sample was
/// accepted (`Ok`, the forecast was made before it) and poisoned the state:
/// after 1e300, -1e300, f64::MAX the innovation `MAX - yhat` (yhat about
/// -1e300) overflows and `e[0] = inf` is stored. Even a single f64::MAX
/// after ordinary samples leaves `z[0] = 2.9e307`, from which every later
/// forecast overflows. Either way every later step fails with
/// `NonFiniteOutput` and, as failed steps do not commit, the model never
/// recovered until its state was reset. `step` now refuses inputs beyond
/// `MAX_INPUT_MAGNITUDE` and any step whose new ARMA state is not finite.
#[test]
fn arma_state_stays_finite_after_extreme_input() {
    let vm = valid(arma_2_1_d1());
    for extreme in [&[1e300, -1e300, f64::MAX][..], &[f64::MAX][..]] {
        let mut state = ModelState::new();
        let mut out = [0.0];
        for y in [20.0, 21.0, 22.0, 23.0] {
            vm.step(&mut state, &[y], &mut out)
                .expect("ordinary sample");
        }
        for y in extreme {
            let _ = vm.step(&mut state, &[*y], &mut out);
            assert!(state_is_finite(&state), "after {y:e}: {state:?}");
        }
        vm.step(&mut state, &[24.0], &mut out)
            .expect("an ordinary sample after an extreme one is accepted");
    }
}

/// The blob in two pieces, split anywhere in the header (how the hub checks
/// an upload: magic in RAM, the rest in flash), decodes exactly as the
/// whole, and a change in either piece gives the same error as in the whole.
#[test]
fn split_decode_agrees_with_whole_decode_at_every_header_split() {
    for (label, model) in models() {
        let good = blob_of(&valid(model));
        let whole = decode(&good).expect("decodes");
        for split in 0..=HEADER_LEN {
            let (head, tail) = good.split_at(split);
            let parts = blob::decode_split(head, tail).expect("split decodes");
            assert_eq!(parts.model(), whole.model(), "{label}: split at {split}");
            for at in [0, 5, 9, 11, 12, good.len() / 2, good.len() - 1] {
                let mut bad = good.clone();
                bad[at] ^= 0x5A;
                let (h, t) = bad.split_at(split);
                assert_eq!(
                    blob::decode_split(h, t).map(|_| ()),
                    decode(&bad).map(|_| ()),
                    "{label}: split at {split}, byte {at} changed"
                );
            }
        }
        // A head longer than the header cannot be one of the hub's pieces.
        let (head, tail) = good.split_at(HEADER_LEN + 1);
        assert_eq!(
            blob::decode_split(head, tail).map(|_| ()),
            Err(BlobError::Malformed),
            "{label}"
        );
    }
}

/// CRC fed in pieces equals the CRC of the whole, for every split point.
#[test]
fn streaming_crc_equals_one_shot_crc() {
    let bytes: Vec<u8> = (0..=255u8).cycle().take(700).collect();
    for split in 0..bytes.len() {
        let (a, b) = bytes.split_at(split);
        let streamed = blob::Crc32::new().update(a).update(b).finish();
        assert_eq!(streamed, crc32(&bytes), "split at {split}");
    }
}

/// Lists are decoded through one capacity-erased visitor (`wire.rs`): a
/// list at capacity decodes, one element more is refused, as heapless's
/// own decoder did. Checked on the position polynomial (capacity 8).
#[test]
fn a_list_longer_than_its_capacity_is_refused() {
    #[derive(serde::Serialize)]
    struct Wide {
        channel: u8,
        poly: Vec<f64>,
        k0: f64,
    }
    let cap = model_core::position::MAX_POLY_COEFFS;
    for (n, fits) in [(0, true), (cap, true), (cap + 1, false), (40, false)] {
        let wide = Wide {
            channel: 3,
            poly: (0..n).map(|k| k as f64 * 0.5).collect(),
            k0: -0.25,
        };
        let mut buf = [0u8; 1024];
        let bytes = postcard::to_slice(&wide, &mut buf).unwrap();
        let got: Result<PositionTerm, _> = postcard::from_bytes(bytes);
        match got {
            Ok(p) => {
                assert!(fits, "{n} elements must be refused");
                assert_eq!(p.poly.as_slice(), wide.poly.as_slice());
                assert_eq!((p.channel, p.k0), (3, -0.25));
            }
            Err(_) => assert!(!fits, "{n} elements must decode"),
        }
    }
}

/// Issue 14: a linear, PCR or BP model that computes one output twice was
/// accepted, stored and shown, but only the last equation ran. Every kind
/// now refuses it, the decoder included, as the filter bank always did.
#[test]
fn an_output_computed_twice_is_refused() {
    let mut lin = linear_seed002();
    if let Params::Linear(l) = &mut lin.params {
        let mut second = l.outputs[0].clone();
        second.intercept = 1.0;
        l.outputs.push(second).expect("room");
    }
    refused_both_ways("linear", lin, ModelError::DuplicateOutput { output: 0 });
    let pcr = with_pcr(|p| {
        let mut second = p.outputs[0].clone();
        second.intercept = 1.0;
        p.outputs.push(second).expect("room");
    });
    refused_both_ways("pcr", pcr, ModelError::DuplicateOutput { output: 0 });
    let bp = with_bp(|n| {
        let o = n.outputs[0];
        n.outputs[1] = o;
    });
    refused_both_ways("bp", bp, ModelError::DuplicateOutput { output: 0 });
}
