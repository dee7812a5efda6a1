//! Fuzzes `model_core::decode` and, when a blob is accepted, `ValidModel::step`.
//!
//! The first byte picks the mode. Odd: the rest is decoded as it is, so the
//! framing checks (length, magic, version, length field, CRC) are fuzzed.
//! Even: the rest is a model body, wrapped here in a correct header and CRC
//! for the kind code `byte >> 1`, so that libFuzzer spends its time in the
//! postcard body decoder and `Model::validate` instead of rediscovering
//! CRC-32 (which random mutation passes once in 4 billion tries).
//!
//! On a decoded model, 100 steps run with inputs read from the data as f64
//! (so NaN, infinities and extremes occur). The invariants checked are the
//! ones `model.rs` promises: no panic, no non-finite output on `Ok`, and an
//! untouched output buffer on `Err`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use model_core::blob::{crc32, FORMAT_VERSION, HEADER_LEN, MAGIC, MAX_BLOB_LEN};
use model_core::ModelState;

/// `body` in a correct frame (see model-core/src/blob.rs), into `buf`.
fn frame(kind_code: u8, body: &[u8], buf: &mut [u8; MAX_BLOB_LEN]) -> Option<usize> {
    let total = HEADER_LEN + body.len() + 4;
    if total > MAX_BLOB_LEN {
        return None;
    }
    buf[..4].copy_from_slice(&MAGIC);
    buf[4..6].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    buf[6] = kind_code;
    buf[7] = 0;
    buf[8..12].copy_from_slice(&(body.len() as u32).to_le_bytes());
    buf[HEADER_LEN..HEADER_LEN + body.len()].copy_from_slice(body);
    let crc = crc32(&buf[..HEADER_LEN + body.len()]);
    buf[HEADER_LEN + body.len()..total].copy_from_slice(&crc.to_le_bytes());
    Some(total)
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let mut buf = [0u8; MAX_BLOB_LEN];
    let blob: &[u8] = if mode & 1 == 1 {
        rest
    } else {
        match frame(mode >> 1, rest, &mut buf) {
            Some(n) => &buf[..n],
            None => return,
        }
    };
    let Ok(model) = model_core::decode(blob) else {
        return;
    };

    // Inputs: consecutive 8-byte windows of the data, wrapping around, as
    // f64 little-endian bit patterns.
    let n_in = model.inputs().len();
    let n_out = model.outputs().len();
    let mut state = ModelState::new();
    let mut at = 0usize;
    let mut x = [0.0f64; model_core::model::MAX_CHANNELS];
    for _ in 0..100 {
        for xi in x.iter_mut().take(n_in) {
            let mut b = [0u8; 8];
            for byte in b.iter_mut() {
                *byte = data[at % data.len()];
                at += 1;
            }
            *xi = f64::from_le_bytes(b);
        }
        let sentinel = f64::from_bits(0x7FF0_DEAD_BEEF_0001);
        let mut out = [sentinel; model_core::model::MAX_OUTPUTS];
        match model.step(&mut state, &x[..n_in], &mut out) {
            Ok(()) => assert!(
                out[..n_out].iter().all(|v| v.is_finite()),
                "non-finite output {out:?} for inputs {:?}",
                &x[..n_in]
            ),
            Err(e) => assert!(
                out.iter().all(|v| v.to_bits() == sentinel.to_bits()),
                "{e:?} wrote {out:?}"
            ),
        }
    }
});
