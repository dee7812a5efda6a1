//! Host cost of one model update (`ValidModel::step`) per model kind at the
//! sizes the seed papers use, of decoding (and so validating) each model's
//! blob, and of one RTD conversion.
//!
//! Why these: the hub samples at about 1 Hz, so an update has a budget of
//! milliseconds even in soft-float f64 on the Cortex-M4F; what matters is how
//! the kinds compare and that nothing is accidentally quadratic. Decoding is
//! the slow path, run once when a model is flashed: validation finds the
//! roots of every TF's numerator and denominator. The host numbers here are
//! relative; on-chip cycles are measured separately (docs/benchmarks.md).
//!
//! `cargo bench -p model-core --bench update` (about a minute: 2 s of
//! measurement and 50 samples per case).

#[path = "../tests/common/mod.rs"]
mod common;

use common::{
    arma_2_1_d1, bp, fbank_3x2, fbank_wide, linear_seed002, pcr_seed003, tf_bank_4x4,
    tf_sp1_ambient,
};
use criterion::Criterion;
use model_core::blob::{self, MAX_BLOB_LEN};
use model_core::rtd::Rtd;
use model_core::{ModelState, ValidModel};
use std::hint::black_box;
use std::time::Duration;

/// The models timed, at the sizes the seed papers use (fixtures in
/// `tests/common/mod.rs`).
fn cases() -> Vec<(&'static str, ValidModel)> {
    [
        ("tf_sp1_ambient_2x", tf_sp1_ambient()),
        ("tf_bank_4x_order4", tf_bank_4x4()),
        ("linear_4in", linear_seed002()),
        ("pcr_5in_1pc", pcr_seed003(false)),
        ("pcr_5in_1pc_position", pcr_seed003(true)),
        ("bp_4x11x3", bp(4, 11)),
        ("bp_16x24x3", bp(16, 24)),
        ("arma_2_1_d1", arma_2_1_d1()),
        ("fbank_3in_5f_2out", fbank_3x2(true)),
        ("fbank_32in_x4", fbank_wide(32)),
    ]
    .into_iter()
    .map(|(label, m)| (label, m.validate().expect("bench model is valid")))
    .collect()
}

/// Raw inputs of a warm machine: temperatures in C (and a position in mm).
fn inputs(vm: &ValidModel) -> Vec<f64> {
    (0..vm.inputs().len())
        .map(|i| 24.0 + 0.25 * i as f64)
        .collect()
}

fn step(c: &mut Criterion) {
    let mut g = c.benchmark_group("step");
    for (label, vm) in cases() {
        let x = inputs(&vm);
        let mut state = ModelState::new();
        let mut out = [0.0; 4];
        // The first sample sets references and steady-state histories; time
        // the updates that follow it.
        vm.step(&mut state, &x, &mut out).expect("finite inputs");
        g.bench_function(label, |b| {
            b.iter(|| {
                vm.step(&mut state, black_box(&x), black_box(&mut out))
                    .expect("finite inputs")
            })
        });
    }
    g.finish();
}

fn decode(c: &mut Criterion) {
    let mut g = c.benchmark_group("decode");
    for (label, vm) in cases() {
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = blob::encode(&vm, &mut buf).expect("encodes");
        let bytes = &buf[..n];
        g.bench_function(format!("{label} ({n} B)"), |b| {
            b.iter(|| model_core::decode(black_box(bytes)).expect("valid blob"))
        });
    }
    g.finish();
}

fn rtd(c: &mut Criterion) {
    let mut g = c.benchmark_group("rtd");
    // R(+100 C) = 138.5055 ohm: closed-form branch. R(-50 C) = 80.3063 ohm:
    // Newton on the full CVD equation (the C term applies below 0 C).
    for (label, r_ohm) in [("pt100_above_0c", 138.5055), ("pt100_below_0c", 80.3063)] {
        g.bench_function(label, |b| {
            b.iter(|| {
                Rtd::PT100
                    .temperature_c(black_box(r_ohm))
                    .expect("in range")
            })
        });
    }
    g.finish();
}

/// What `criterion_group!`/`criterion_main!` would generate, written out so
/// that no undocumented public function trips the workspace's `missing_docs`.
fn main() {
    let mut c = Criterion::default()
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500))
        .sample_size(50)
        .configure_from_args();
    step(&mut c);
    decode(&mut c);
    rtd(&mut c);
    c.final_summary();
}
