//! The sample -> validate -> model -> limit pipeline on the host, against
//! hand-computed numbers (tolerances stated per assertion) and properties.
//!
//! Models are built the way `hub.rs`'s tests build them: model-core types,
//! `Model::validate`, `model_core::encode`, then `Hub::load` on the bytes,
//! exactly the path a flashed blob takes.
#![cfg(feature = "model")]

use firmware::hub::{Hub, MAX_OUTPUTS};
use firmware::limiter::LimiterConfig;
use firmware::pipeline::{ChannelFault, Pipeline, PipelineConfig, Reading};
use firmware::report::{HubState, Report, StatusFlags};
use firmware::supervisor::SupervisorConfig;
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::rtd::{Ratiometric, Rtd};
use model_core::tf::TfEntry;
use model_core::{Channel, Model, Name, Params, Reference, ValidModel};
use proptest::prelude::*;

/// Rounding slack for offsets computed as sums of a few um-sized terms.
const ATOL_UM: f64 = 1e-9;

fn name(s: &str) -> Name {
    Name::try_from(s).unwrap()
}

fn vec<T: Clone, const N: usize>(items: &[T]) -> heapless::Vec<T, N> {
    heapless::Vec::from_slice(items).unwrap()
}

fn against_20c(n: &str) -> Channel {
    Channel {
        name: name(n),
        reference: Reference::Value(20.0),
    }
}

/// `out = gain * (input - 20 C)` per (output name, input index, gain).
fn linear(inputs: &[&str], outputs: &[(&str, u8, f64)]) -> ValidModel {
    let channels: Vec<Channel> = inputs.iter().map(|n| against_20c(n)).collect();
    let names: Vec<Name> = outputs.iter().map(|(n, _, _)| name(n)).collect();
    let regressions: Vec<LinearOutput> = outputs
        .iter()
        .enumerate()
        .map(|(i, (_, input, gain))| LinearOutput {
            output: u8::try_from(i).unwrap(),
            intercept: 0.0,
            coef: vec(&[Coef {
                channel: *input,
                value: *gain,
            }]),
            position: None,
        })
        .collect();
    Model {
        inputs: vec(&channels),
        outputs: vec(&names),
        dt_s: 0.0,
        params: Params::Linear(Linear {
            outputs: vec(&regressions),
        }),
        bounds: None,
        five_point: None,
    }
    .validate()
    .unwrap()
}

/// dz_um = 10 um/K * (T1 - 20), dx_um = -4 um/K * (T2 - 20).
fn two_axis() -> ValidModel {
    linear(&["T1", "T2"], &[("dz_um", 0, 10.0), ("dx_um", 1, -4.0)])
}

/// The same offsets at T1 = T2, both read from T1: a T1 fault hits both.
fn both_read_t1() -> ValidModel {
    linear(&["T1", "T2"], &[("dz_um", 0, 10.0), ("dx_um", 0, -4.0)])
}

/// seed 004's form, first order: 0.5 y(k) = 0.1 u(k) + 0.4 y(k-1), u = T1
/// minus its first sample, so y(k) = 0.2 u(k) + 0.8 y(k-1).
fn tf_model() -> ValidModel {
    Model {
        inputs: vec(&[Channel {
            name: name("T1"),
            reference: Reference::First,
        }]),
        outputs: vec(&[name("dz_um")]),
        dt_s: 1.0,
        params: Params::Tf(vec(&[TfEntry {
            output: 0,
            input: 0,
            a: vec(&[0.1]),
            b: vec(&[0.5, -0.4]),
        }])),
        bounds: None,
        five_point: None,
    }
    .validate()
    .unwrap()
}

/// The hub a blob of `model` in a slot loads into.
fn hub(model: &ValidModel) -> Hub {
    let mut slot = vec![0xFF; 8192];
    model_core::encode(model, &mut slot).unwrap();
    let hub = Hub::load(&slot);
    assert_eq!(hub.load_error(), None);
    hub
}

fn pipeline(model: &ValidModel) -> Pipeline {
    Pipeline::new(hub(model), PipelineConfig::DEFAULT).unwrap()
}

fn temps(t1: f64, t2: f64) -> [Reading; 2] {
    [Reading::Value(t1), Reading::Value(t2)]
}

/// Runs `n` identical samples and returns the last report.
fn settle(p: &mut Pipeline, readings: &[Reading], n: usize) -> Report {
    let mut last = None;
    for _ in 0..n {
        last = Some(p.on_sample(readings));
    }
    last.unwrap()
}

/// Steady state at T1 = 25 C, T2 = 25 C: dz = 50 um, dx = -20 um
/// (reached through the 2 um/s slew limit in 25 samples).
fn running_at_50_and_minus_20(model: &ValidModel) -> (Pipeline, Report) {
    let mut p = pipeline(model);
    let r = settle(&mut p, &temps(25.0, 25.0), 30);
    assert_eq!(r.state, HubState::Running);
    assert!((r.offsets[0] - 50.0).abs() < ATOL_UM, "{r:?}");
    assert!((r.offsets[1] + 20.0).abs() < ATOL_UM, "{r:?}");
    assert_eq!(r.flags, StatusFlags::default());
    (p, r)
}

#[test]
fn start_up_slews_from_zero() {
    let mut p = pipeline(&two_axis());
    // dz target 50, dx target -20; 2 um per 1 s sample, exact.
    for k in 1..=25 {
        let r = p.on_sample(&temps(25.0, 25.0));
        let dz = (2.0 * k as f64).min(50.0);
        let dx = -(2.0 * k as f64).min(20.0);
        assert_eq!((r.offsets[0], r.offsets[1]), (dz, dx), "sample {k}");
        assert_eq!(r.state, HubState::Running);
        assert_eq!(r.n_outputs, 2);
        assert_eq!(r.flags.has(StatusFlags::SLEW_LIMITED), k < 25);
    }
}

#[test]
fn three_mm_spike_is_rejected_and_offsets_do_not_move() {
    let (mut p, before) = running_at_50_and_minus_20(&two_axis());
    // +90 K on T1 = 900 um of dz in one sample (seed 002's S2 spike is
    // 5.29 mm; a jump beyond 120 C would be refused as implausible first).
    let r = p.on_sample(&temps(115.0, 25.0));
    assert_eq!(r.offsets, before.offsets, "bit for bit");
    assert_eq!(r.state, HubState::Holding);
    assert!(r.flags.has(StatusFlags::SPIKE_REJECTED));
    assert!(!r.flags.has(StatusFlags::SENSOR_FAULT));
    assert_eq!(r.faulty_channels, 0b01);
    assert_eq!(p.hub().faults().total(), 0, "the model never saw it");
    // The next normal sample runs on, nothing moved.
    let r = p.on_sample(&temps(25.0, 25.0));
    assert_eq!(r.state, HubState::Running);
    assert_eq!(r.offsets, before.offsets);
    assert_eq!(r.flags, StatusFlags::default());
}

#[test]
fn real_step_persisting_n_samples_is_accepted() {
    let (mut p, before) = running_at_50_and_minus_20(&two_axis());
    let n = usize::from(PipelineConfig::DEFAULT.spike.persist_samples);
    assert_eq!(n, 3);
    // T1 steps 25 -> 28 C (3 K > the 1 K limit at 1 s) and stays there.
    for k in 1..n {
        let r = p.on_sample(&temps(28.0, 25.0));
        assert_eq!(r.state, HubState::Holding, "sample {k}");
        assert!(r.flags.has(StatusFlags::SPIKE_REJECTED));
        assert_eq!(r.offsets, before.offsets);
    }
    // The N-th sample at the new level is accepted: target dz = 80 um.
    let r = p.on_sample(&temps(28.0, 25.0));
    assert_eq!(r.state, HubState::Running);
    assert!(!r.flags.has(StatusFlags::SPIKE_REJECTED));
    assert!(r.flags.has(StatusFlags::SLEW_LIMITED));
    assert!((r.offsets[0] - 52.0).abs() < ATOL_UM, "{r:?}");
    // Then it follows: 14 more samples of 2 um reach 80.
    let r = settle(&mut p, &temps(28.1, 25.0), 14);
    assert!((r.offsets[0] - 80.0).abs() < ATOL_UM, "{r:?}");
    let r = p.on_sample(&temps(28.1, 25.0));
    assert!((r.offsets[0] - 81.0).abs() < ATOL_UM, "{r:?}");
}

/// PT100 code for `t_c` on the board's MAX31865 (400 ohm reference).
fn code(t_c: f64) -> u16 {
    let r = Rtd::PT100.resistance_ohm(t_c).unwrap();
    let c = Ratiometric::MAX31865_PT100.code_for_resistance(r).unwrap();
    u16::try_from(c.0).unwrap()
}

#[test]
fn open_rtd_holds_for_the_hold_time_then_ramps_to_zero_then_recovers() {
    // RTD codes all the way: 25 C is code 8989 = 109.729 ohm = 24.9854 C
    // (the 12.2 mohm code step is 0.03 K; checked with the CVD inverse in Python).
    let good = [Reading::pt100(code(25.0)), Reading::pt100(code(25.0))];
    let Reading::Value(t_meas) = good[0] else {
        panic!("{:?}", good[0]);
    };
    assert!((t_meas - 24.985_43).abs() < 1e-5, "{t_meas}");
    let mut p = pipeline(&both_read_t1());
    let steady = settle(&mut p, &good, 40);
    let (dz0, dx0) = (10.0 * (t_meas - 20.0), -4.0 * (t_meas - 20.0));
    assert!((steady.offsets[0] - dz0).abs() < ATOL_UM);
    assert!((steady.offsets[1] - dx0).abs() < ATOL_UM);

    // T1's RTD (read by both outputs) opens: the converter reads its top code.
    let open = [Reading::pt100(0x7FFF), good[1]];
    assert_eq!(open[0], Reading::Fault(ChannelFault::Open));
    let hold = SupervisorConfig::DEFAULT.hold_time_s; // 60 s = 60 samples at 1 s
    for k in 0..60 {
        let r = p.on_sample(&open);
        assert_eq!(r.state, HubState::Holding, "fault sample {k}");
        assert_eq!(r.offsets, steady.offsets, "held bit for bit, sample {k}");
        assert_eq!(r.flags, StatusFlags(StatusFlags::SENSOR_FAULT));
        assert_eq!(r.faulty_channels, 0b01);
    }
    assert_eq!(hold, 60.0);

    // Ramp at 1 um/s = 1 um per sample, each output towards zero; dx
    // (|dx0| = 19.94) is zero after 20 ramp samples, dz (49.85) after 50.
    let ramp = SupervisorConfig::DEFAULT.ramp_um_per_s;
    let zero_dx = (dx0.abs() / ramp).ceil() as usize;
    let zero_dz = (dz0.abs() / ramp).ceil() as usize;
    assert_eq!((zero_dx, zero_dz), (20, 50));
    for m in 1..=zero_dz {
        let r = p.on_sample(&open);
        let dz = (dz0 - ramp * m as f64).max(0.0);
        let dx = (dx0 + ramp * m as f64).min(0.0);
        assert!((r.offsets[0] - dz).abs() < ATOL_UM, "ramp {m}: {r:?}");
        assert!((r.offsets[1] - dx).abs() < ATOL_UM, "ramp {m}: {r:?}");
        assert_eq!(r.offsets[1] == 0.0, m >= zero_dx, "ramp {m}");
        let expected = if m < zero_dz {
            HubState::Ramping
        } else {
            HubState::Zeroed
        };
        assert_eq!(r.state, expected, "ramp {m}");
        assert_eq!(r.flags, StatusFlags(StatusFlags::SENSOR_FAULT));
    }
    // Zeroed stays zero while the fault lasts.
    let r = settle(&mut p, &open, 100);
    assert_eq!((r.state, r.offsets), (HubState::Zeroed, [0.0; MAX_OUTPUTS]));

    // Recovery: the input failed (fault past the hold time), so it must
    // read good for the recovery time (10 samples) before the offsets
    // follow again; meanwhile they stay at zero, flagged RECOVERING.
    let recover = SupervisorConfig::DEFAULT.recover_samples(1.0);
    assert_eq!(recover, 10);
    for k in 1..recover {
        let r = p.on_sample(&good);
        assert_eq!(
            (r.state, r.offsets),
            (HubState::Zeroed, [0.0; MAX_OUTPUTS]),
            "{k}"
        );
        assert_eq!(r.flags, StatusFlags(StatusFlags::RECOVERING), "{k}");
    }
    // Then Running, offsets climb back at the slew rate.
    for k in 1..=5 {
        let r = p.on_sample(&good);
        assert_eq!(r.state, HubState::Running);
        assert_eq!(r.faulty_channels, 0);
        assert_eq!(
            (r.offsets[0], r.offsets[1]),
            (2.0 * k as f64, -2.0 * k as f64)
        );
    }
    let r = settle(&mut p, &good, 30);
    assert!((r.offsets[0] - dz0).abs() < ATOL_UM && (r.offsets[1] - dx0).abs() < ATOL_UM);
    assert_eq!(r.flags, StatusFlags::default());
}

/// One output's sensor fails: only the output that reads it holds and
/// ramps; the other keeps following its own sensor (here through a real
/// warm-up during the fault). The model keeps stepping with the failed
/// input's last good value standing in. The hub state is the worst
/// output's.
#[test]
fn a_fault_holds_only_the_outputs_that_read_the_failed_input() {
    let (mut p, before) = running_at_50_and_minus_20(&two_axis());
    for k in 0..60 {
        // T1 warms 25 -> 26.2 C over the hold time; T2 is open.
        let t1 = 25.0 + 0.02 * f64::from(k + 1);
        let r = p.on_sample(&[Reading::Value(t1), Reading::Fault(ChannelFault::Open)]);
        assert_eq!(r.state, HubState::Holding, "{k}");
        assert_eq!(r.faulty_channels, 0b10);
        assert!(
            (r.offsets[0] - 10.0 * (t1 - 20.0)).abs() < ATOL_UM,
            "dz follows: {r:?}"
        );
        assert_eq!(r.offsets[1], before.offsets[1], "dx held, sample {k}");
    }
    let bad = [Reading::Value(26.2), Reading::Fault(ChannelFault::Open)];
    for m in 1..=20 {
        let r = p.on_sample(&bad);
        assert!((r.offsets[0] - 62.0).abs() < ATOL_UM, "{r:?}");
        assert!(
            (r.offsets[1] - (-20.0 + f64::from(m))).abs() < ATOL_UM,
            "{r:?}"
        );
        let zeroed = m == 20;
        let want = if zeroed {
            HubState::Zeroed
        } else {
            HubState::Ramping
        };
        assert_eq!(r.state, want, "ramp {m}");
    }
}

#[test]
fn recovery_during_the_ramp_slews_back_without_a_jump() {
    let (mut p, _) = running_at_50_and_minus_20(&both_read_t1());
    let bad = [Reading::Fault(ChannelFault::Bus), Reading::Value(25.0)];
    settle(&mut p, &bad, 60 + 10); // hold, then 10 ramp samples
    let r = p.on_sample(&bad);
    assert_eq!(r.state, HubState::Ramping);
    assert!((r.offsets[0] - 39.0).abs() < ATOL_UM, "{r:?}");
    assert!((r.offsets[1] + 9.0).abs() < ATOL_UM, "{r:?}");
    // Good again: the ramp goes on through the recovery time (10 samples,
    // the 10th already follows), then the offsets slew back from there.
    for k in 1..10 {
        let r = p.on_sample(&temps(25.0, 25.0));
        assert_eq!(r.state, HubState::Ramping, "{k}");
        assert!(r.flags.has(StatusFlags::RECOVERING));
        assert!((r.offsets[0] - (39.0 - k as f64)).abs() < ATOL_UM, "{r:?}");
        assert!((r.offsets[1] + (9.0 - k as f64)).abs() < ATOL_UM, "{r:?}");
    }
    let r = p.on_sample(&temps(25.0, 25.0));
    assert_eq!(r.state, HubState::Running);
    assert!((r.offsets[0] - 32.0).abs() < ATOL_UM, "{r:?}");
    assert!((r.offsets[1] + 2.0).abs() < ATOL_UM, "{r:?}");
}

#[test]
fn slew_limit_and_clamp_are_exact_per_output() {
    let mut config = PipelineConfig::DEFAULT;
    config.limiter = LimiterConfig {
        slew_um_per_s: [50.0, 5.0, 2.0, 2.0],
        clamp_um: [100.0, 30.0, 500.0, 500.0],
    };
    let mut p = Pipeline::new(hub(&two_axis()), config).unwrap();
    // Targets: dz = 10 * 80 = 800 um, dx = -4 * 80 = -320 um; both beyond the clamp.
    let hot = temps(100.0, 100.0);
    let expect_dx = [-5.0, -10.0, -15.0, -20.0, -25.0, -30.0, -30.0, -30.0];
    for (k, dx) in expect_dx.iter().enumerate() {
        let r = p.on_sample(&hot);
        let dz = if k == 0 { 50.0 } else { 100.0 };
        assert_eq!((r.offsets[0], r.offsets[1]), (dz, *dx), "sample {k}");
        assert!(r.flags.has(StatusFlags::CLAMPED));
        // dz needs one full step after the first (not "limited"), dx six.
        assert_eq!(r.flags.has(StatusFlags::SLEW_LIMITED), k < 5, "sample {k}");
        assert_eq!(r.state, HubState::Running);
    }
}

#[test]
fn a_stale_sample_holds_for_that_sample_only() {
    let (mut p, before) = running_at_50_and_minus_20(&two_axis());
    let r = p.on_sample(&[Reading::Value(25.0), Reading::Stale]);
    assert_eq!(r.state, HubState::Holding);
    assert_eq!(r.flags, StatusFlags(StatusFlags::STALE));
    assert_eq!(r.faulty_channels, 0b10);
    assert_eq!(r.offsets, before.offsets);
    let r = p.on_sample(&temps(25.0, 25.0));
    assert_eq!(
        (r.state, r.flags),
        (HubState::Running, StatusFlags::default())
    );
    // Several causes at once all show.
    let r = p.on_sample(&[Reading::Stale, Reading::Fault(ChannelFault::Short)]);
    assert!(r.flags.has(StatusFlags::STALE | StatusFlags::SENSOR_FAULT));
    assert_eq!(r.faulty_channels, 0b11);
}

#[test]
fn no_model_gives_zeros_and_says_so() {
    let erased = [0xFF; 1024];
    let mut p = Pipeline::new(Hub::load(&erased), PipelineConfig::DEFAULT).unwrap();
    for readings in [
        &temps(25.0, 25.0)[..],
        &[Reading::Value(f64::NAN)][..],
        &[][..],
    ] {
        let r = p.on_sample(readings);
        assert_eq!(r.offsets, [0.0; MAX_OUTPUTS]);
        assert_eq!(r.n_outputs, 0);
        assert_eq!(r.state, HubState::NoModel);
        assert_eq!(r.flags, StatusFlags(StatusFlags::NO_MODEL));
        assert_eq!(r.faulty_channels, 0);
    }
}

#[test]
fn model_swap_mid_run_continues_without_a_jump() {
    let (mut p, before) = running_at_50_and_minus_20(&two_axis());
    // The new model lists its outputs the other way round and doubles dz:
    // dx_um = -4 (T2 - 20), dz_um = 20 (T1 - 20).
    let new = linear(&["T1", "T2"], &[("dx_um", 1, -4.0), ("dz_um", 0, 20.0)]);
    p.swap_model(&mut hub(&new)).unwrap();
    let r = p.on_sample(&temps(25.0, 25.0));
    assert_eq!(r.state, HubState::Running);
    // By name: dx stays at -20, dz moves one slew step from 50 towards 100.
    assert!((r.offsets[0] + 20.0).abs() < ATOL_UM, "{r:?}");
    assert!((r.offsets[1] - 52.0).abs() < ATOL_UM, "{r:?}");
    assert!((r.offsets[1] - before.offsets[0]).abs() <= 2.0 + ATOL_UM);
    let r = settle(&mut p, &temps(25.0, 25.0), 24);
    assert!((r.offsets[1] - 100.0).abs() < ATOL_UM, "{r:?}");
}

#[test]
fn swap_to_a_dynamic_model_restarts_its_state_and_period() {
    let (mut p, _) = running_at_50_and_minus_20(&two_axis());
    p.swap_model(&mut hub(&tf_model())).unwrap();
    assert_eq!(p.sample_period_ms(), 1000);
    // The TF restarts at steady state (reference = this sample): target 0,
    // so dz leaves 50 at the slew rate; dx is gone from the report.
    let r = p.on_sample(&[Reading::Value(25.0)]);
    assert_eq!(r.n_outputs, 1);
    assert!((r.offsets[0] - 48.0).abs() < ATOL_UM, "{r:?}");
    assert_eq!(&r.offsets[1..], &[0.0; MAX_OUTPUTS - 1]);
}

#[test]
fn a_fault_keeps_a_dynamic_models_time_base() {
    // y(k) = 0.2 u(k) + 0.8 y(k-1) with u = 1 K after the first sample:
    // 0.2, 0.36, 0.488, 0.5904, 0.67232 ...; all within one slew step,
    // so the offsets are the model's outputs (1e-12: a few roundings).
    let mut expected = vec![0.0];
    for _ in 0..10 {
        let last = expected[expected.len() - 1];
        expected.push(0.2 + 0.8 * last);
    }
    let mut p = pipeline(&tf_model());
    let got = [25.0, 26.0, 26.0].map(|t| p.on_sample(&[Reading::Value(t)]).offsets[0]);
    // Five faulty samples: the offset held, the model stepped with the
    // last good value (26 C, the true value here) standing in.
    for _ in 0..5 {
        let r = p.on_sample(&[Reading::Fault(ChannelFault::Open)]);
        assert_eq!(r.offsets[0], got[2]);
    }
    // The sequence carries on in time, as if the fault had not happened
    // (samples 8, 9, 10): no lag by the fault's length.
    let after: Vec<f64> = (0..3)
        .map(|_| p.on_sample(&[Reading::Value(26.0)]).offsets[0])
        .collect();
    for (g, e) in got.iter().zip(&expected[..3]) {
        assert!((g - e).abs() < 1e-12, "{got:?}");
    }
    for (g, e) in after.iter().zip(&expected[8..]) {
        assert!((g - e).abs() < 1e-12, "{after:?} {expected:?}");
    }
    assert_eq!(p.hub().faults().total(), 0);
}

#[test]
fn default_config_is_printed_in_the_docs_units() {
    // The numbers the docs give reasons for; a change here must change them.
    let c = PipelineConfig::DEFAULT;
    assert_eq!(c.default_sample_period_s, 1.0);
    assert_eq!(
        (
            c.spike.max_rate_k_per_s,
            c.spike.noise_k,
            c.spike.persist_samples
        ),
        (0.5, 0.5, 3)
    );
    assert_eq!(
        (c.supervisor.hold_time_s, c.supervisor.ramp_um_per_s),
        (60.0, 1.0)
    );
    assert_eq!(c.limiter, LimiterConfig::DEFAULT);
    assert_eq!(
        (
            LimiterConfig::DEFAULT_SLEW_UM_PER_S,
            LimiterConfig::DEFAULT_CLAMP_UM
        ),
        (2.0, 500.0)
    );
}

// ---------------------------------------------------------------------------
// Property: whatever arrives, every offset is finite, within the clamp, and
// moves by at most slew * dt per sample.

fn any_fault() -> impl Strategy<Value = ChannelFault> {
    prop_oneof![
        Just(ChannelFault::Open),
        Just(ChannelFault::Short),
        Just(ChannelFault::OutOfRange),
        Just(ChannelFault::Bus),
        Just(ChannelFault::Converter),
    ]
}

fn any_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        // Plausible temperatures, so the model runs most of the time and
        // the clamp is reached (100 um/K below).
        4 => 15.0..35.0f64,
        // Anything on the RTD curve: spikes and real steps.
        1 => -200.0..850.0f64,
        // Any bit pattern: NaN, infinities, subnormals, huge.
        1 => any::<f64>(),
        1 => prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY),
                         Just(f64::MAX), Just(-1e300), Just(1e9)],
    ]
}

fn any_reading() -> impl Strategy<Value = Reading> {
    prop_oneof![
        6 => any_value().prop_map(Reading::Value),
        1 => any_value().prop_map(Reading::Direct),
        1 => any_fault().prop_map(Reading::Fault),
        1 => Just(Reading::Stale),
    ]
}

/// Short hold so that runs reach the ramp; per-output rates and clamps.
fn prop_config() -> PipelineConfig {
    let mut c = PipelineConfig::DEFAULT;
    c.supervisor.hold_time_s = 3.0;
    c.limiter = LimiterConfig {
        slew_um_per_s: [2.0, 7.5, 2.0, 2.0],
        clamp_um: [500.0, 40.0, 500.0, 500.0],
    };
    c
}

fn check_run(model: &ValidModel, samples: &[Vec<Reading>]) -> Result<(), TestCaseError> {
    let config = prop_config();
    let mut p = Pipeline::new(hub(model), config).unwrap();
    let dt = p.sample_period_s();
    let mut prev = [0.0; MAX_OUTPUTS];
    for readings in samples {
        let r = p.on_sample(readings);
        let n = usize::from(r.n_outputs);
        for (i, (o, before)) in r.offsets.iter().zip(&prev).enumerate() {
            prop_assert!(o.is_finite(), "{r:?}");
            if i >= n {
                prop_assert_eq!(*o, 0.0);
                continue;
            }
            prop_assert!(o.abs() <= config.limiter.clamp_um[i], "{r:?}");
            // One step plus rounding of `prev + step` (a few ulps of 500).
            let step = config.limiter.slew_um_per_s[i] * dt;
            prop_assert!((o - before).abs() <= step + 1e-12, "{before} -> {o}");
        }
        prop_assert!(r.state != HubState::NoModel);
        if r.state == HubState::Running {
            prop_assert_eq!(r.faulty_channels, 0);
        } else {
            // A fault, or a failed input proving itself for the recovery time.
            let causes = 0b1111
                | StatusFlags::RECOVERING
                | StatusFlags::IMPLAUSIBLE
                | StatusFlags::RATE_OF_CHANGE
                | StatusFlags::STUCK;
            prop_assert!(r.flags.0 & causes != 0, "a cause is named: {r:?}");
        }
        prev = r.offsets;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn offsets_stay_finite_clamped_and_slew_limited_linear(
        samples in prop::collection::vec(prop::collection::vec(any_reading(), 0..4), 1..300)
    ) {
        let model = linear(&["T1", "T2"], &[("dz_um", 0, 100.0), ("dx_um", 1, -60.0)]);
        check_run(&model, &samples)?;
    }

    #[test]
    fn offsets_stay_finite_clamped_and_slew_limited_tf(
        samples in prop::collection::vec(prop::collection::vec(any_reading(), 1..2), 1..300)
    ) {
        check_run(&tf_model(), &samples)?;
    }
}
