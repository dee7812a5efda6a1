//! Boot: the pipeline built in its static, and the model to boot loaded
//! into it where it lies (docs/firmware-cost.md, "Stack"). The RTIC app's
//! `init` calls [`boot`] with the static and the two model slots read from
//! flash; the stack bench (`firmware/qemu-bench`, `stack`) measures it.

use core::mem::MaybeUninit;

use crate::pipeline::{Pipeline, ValidConfig};
use crate::upload::{boot_order, Slot};

/// The pipeline `init` starts with, in `slot` (its static): built without a
/// model, then the blob of the slot to boot loaded into it in place. That
/// slot is `b` if it holds the committed model of the highest generation
/// ([`select_boot_slot`](crate::upload::select_boot_slot)), else `a`; the
/// slots are tried in [`boot_order`] and the first that loads stays, so
/// each blob is decoded once, where the model lies. When neither is
/// bootable the pipeline runs without a model, and `hub().load_error()`
/// says why: the refusal of the last slot tried, or, when no record allowed
/// trying one, slot A's blob's own refusal; a blob that loads although no
/// record commits it (slot A's record names another blob) is not kept
/// (`TooShort`, as an empty slot: a model the records do not commit must
/// not compensate). Returns the pipeline and the slot booted (`None`:
/// neither was bootable, and no model runs).
pub fn boot<'a>(
    slot: &'a mut MaybeUninit<Pipeline>,
    config: ValidConfig,
    [a, b]: [&[u8]; 2],
) -> (&'a mut Pipeline, Option<Slot>) {
    let pipeline = without_model_in(slot, config);
    let mut last = None;
    for s in boot_order(a, b) {
        pipeline.load(if s == Slot::B { b } else { a });
        if pipeline.hub().load_error().is_none() {
            return (pipeline, Some(s));
        }
        last = Some(s);
    }
    if last.is_none() {
        pipeline.load(a);
    }
    if pipeline.hub().load_error().is_none() {
        pipeline.load(&[]);
    }
    (pipeline, None)
}

/// [`Pipeline::without_model`] written into `slot`. A frame of its own,
/// never inlined: the pipeline passes through it by value (the deepest
/// path of boot), and that frame is gone before the model is decoded.
#[inline(never)]
fn without_model_in(slot: &mut MaybeUninit<Pipeline>, config: ValidConfig) -> &mut Pipeline {
    slot.write(Pipeline::without_model(config))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hub::Hub;
    use crate::pipeline::PipelineConfig;
    use crate::test_util::{blob, first_order_tf};

    fn booted(a: &[u8], b: &[u8]) -> (std::string::String, Option<Slot>) {
        let mut slot = MaybeUninit::uninit();
        let config = PipelineConfig::DEFAULT.checked().unwrap();
        let (p, active) = boot(&mut slot, config, [a, b]);
        (std::format!("{p:?}"), active)
    }

    fn new(slot: &[u8]) -> std::string::String {
        let p = Pipeline::new(Hub::load(slot), PipelineConfig::DEFAULT).unwrap();
        std::format!("{p:?}")
    }

    /// Slot contents a hub can meet at boot (a 4 KiB slot, the record in
    /// its last 16 bytes): erased; a bare blob; a blob under records of
    /// generations 1 and 5; a blob that frames and decodes but does not
    /// validate, under the highest record; a torn record; a record naming
    /// another blob's CRC.
    fn contents(dt_s: f64) -> std::vec::Vec<std::vec::Vec<u8>> {
        use crate::upload::{CommitRecord, RECORD_LEN};
        const LEN: usize = 4096;
        let good = blob(&first_order_tf("T1", dt_s));
        let mut bad = first_order_tf("T1", dt_s).model().clone();
        bad.dt_s = f64::NAN;
        let bad = crate::test_util::unvalidated_blob(&bad);
        assert!(matches!(
            model_core::decode(&bad),
            Err(model_core::BlobError::Invalid(_))
        ));
        let crc = |b: &[u8]| u32::from_le_bytes(b[b.len() - 4..].try_into().unwrap());
        let slot = |blob: &[u8], record: Option<[u8; RECORD_LEN]>| {
            let mut s = std::vec![0xFF; LEN];
            s[..blob.len()].copy_from_slice(blob);
            if let Some(r) = record {
                s[LEN - RECORD_LEN..].copy_from_slice(&r);
            }
            s
        };
        let record = |generation, blob_crc| CommitRecord {
            generation,
            blob_crc,
        };
        let mut torn = record(7, crc(&good)).to_bytes();
        torn[5] ^= 1;
        std::vec![
            std::vec![0xFF; LEN],
            slot(&good, None),
            slot(&good, Some(record(1, crc(&good)).to_bytes())),
            slot(&good, Some(record(5, crc(&good)).to_bytes())),
            slot(&bad, Some(record(9, crc(&bad)).to_bytes())),
            slot(&good, Some(torn)),
            slot(&good, Some(record(8, crc(&good) ^ 1).to_bytes())),
        ]
    }

    /// Boot, which decodes each slot at most once by trying them in
    /// `boot_order`, boots the slot `select_boot_slot` names (it decodes
    /// both to choose) and the pipeline `new` builds around that slot's
    /// hub, on every pair of contents; with nothing bootable, slot A's
    /// refusal is kept, or no model at all when slot A's blob loads but is
    /// not committed. The two slots hold models with different sample
    /// times, so a hub loaded from the wrong one would show.
    #[test]
    fn boot_boots_the_slot_select_boot_slot_names_on_every_pair_of_contents() {
        let (aa, bb) = (contents(1.0), contents(2.0));
        for (i, a) in aa.iter().enumerate() {
            for (j, b) in bb.iter().enumerate() {
                let expect = crate::upload::select_boot_slot(a, b);
                // With nothing bootable: the last slot tried (B after A)
                // keeps its refusal; none tried, slot A's, unless it loads.
                let tried: std::vec::Vec<Slot> = crate::upload::boot_order(a, b).collect();
                let refused = |s: &[u8]| Hub::load(s).load_error().is_some();
                let loaded: &[u8] = match (expect, tried.last()) {
                    (Some(Slot::B), _) | (None, Some(Slot::B)) => b,
                    (Some(Slot::A), _) | (None, Some(Slot::A)) => a,
                    (None, None) if refused(a) => a,
                    (None, None) => &[],
                };
                let (pipeline, active) = booted(a, b);
                assert_eq!((pipeline, active), (new(loaded), expect), "A {i}, B {j}");
                if active.is_none() {
                    assert!(refused(loaded), "A {i}, B {j}: a model runs");
                }
            }
        }
        // A's blob loads but its record names another blob: no model runs;
        // with a committed B that does not validate, B's refusal is kept.
        let (pipeline, active) = booted(&aa[6], &bb[0]);
        assert_eq!((pipeline, active), (new(&[]), None));
        let (pipeline, active) = booted(&aa[6], &bb[4]);
        assert_eq!((pipeline, active), (new(&bb[4]), None));
        assert!(matches!(
            Hub::load(&bb[4]).load_error(),
            Some(model_core::BlobError::Invalid(_))
        ));
        // The cases where a record outranks a blob that does not load.
        assert_eq!(booted(&aa[3], &bb[4]).1, Some(Slot::A));
        assert_eq!(booted(&aa[4], &bb[2]).1, Some(Slot::B));
    }

    /// A bare valid blob in slot A boots (generation 0), as `new` around
    /// its hub would start; with nothing bootable slot A's refusal is kept.
    #[test]
    fn boot_loads_the_slot_to_boot_as_new_would() {
        let model = blob(&first_order_tf("T1", 1.0));
        let erased = [0xFF; 64];
        assert_eq!(booted(&model, &erased), (new(&model), Some(Slot::A)));
        assert_eq!(booted(&erased, &erased), (new(&erased), None));
    }
}
