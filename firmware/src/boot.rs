//! Boot: the pipeline built in its static, and the model to boot loaded
//! into it where it lies (docs/firmware-cost.md, "Stack"). The RTIC app's
//! `init` calls [`boot`] with the static and the two model slots read from
//! flash; the stack bench (`firmware/qemu-bench`, `stack`) measures it.

use core::mem::MaybeUninit;

use crate::pipeline::{Pipeline, ValidConfig};
use crate::upload::{select_boot_slot, Slot};

/// The pipeline `init` starts with, in `slot` (its static): built without a
/// model, then the blob of the slot to boot loaded into it in place. That
/// slot is `b` if it holds the committed model of the highest generation
/// ([`select_boot_slot`]), else `a`, also when neither is bootable, so
/// that `hub().load_error()` says why. Returns the pipeline and the slot
/// booted (`None`: neither was bootable).
pub fn boot<'a>(
    slot: &'a mut MaybeUninit<Pipeline>,
    config: ValidConfig,
    [a, b]: [&[u8]; 2],
) -> (&'a mut Pipeline, Option<Slot>) {
    let active = select_boot_slot(a, b);
    let pipeline = without_model_in(slot, config);
    pipeline.load(if active == Some(Slot::B) { b } else { a });
    (pipeline, active)
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
