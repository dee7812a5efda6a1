//! Fuzzes the model-spec parser, `host_tools::data::spec::parse`.
//!
//! The input is the spec text (invalid UTF-8 is passed on lossily, so the
//! TOML parser sees it too). The invariants: no panic; an error is one line
//! naming the file; an accepted spec yields a model that encodes to a blob
//! which decodes back to the same model, and steps 50 times with finite
//! outputs on a finite `Ok`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use model_core::blob::{decode, encode_to_vec};
use model_core::ModelState;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match host_tools::data::spec::parse("fuzz.toml", &text) {
        Ok(model) => {
            let blob = encode_to_vec(&model).expect("a valid model encodes");
            let back = decode(&blob).expect("an encoded model decodes");
            assert_eq!(back.model(), model.model(), "round trip");
            let mut state = ModelState::new();
            let inputs = vec![1.0; model.inputs().len()];
            let mut out = vec![0.0; model.outputs().len()];
            for _ in 0..50 {
                if model.step(&mut state, &inputs, &mut out).is_ok() {
                    assert!(out.iter().all(|v| v.is_finite()), "{out:?}");
                }
            }
        }
        Err(e) => {
            let msg = format!("{e:#}");
            assert!(!msg.contains('\n'), "one-line error: {msg:?}");
            assert!(msg.starts_with("fuzz.toml"), "names the file: {msg:?}");
        }
    }
});
