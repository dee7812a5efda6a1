//! Positional outputs on the hub: the position input is fed the reference
//! 0 mm, the offset is zero there, and the thermal slope k(T) - k0 goes to
//! the report (and the SLOPE frame), followed, held, ramped, clamped and
//! slew-limited at the configured stroke like an offset.
#![cfg(feature = "model")]

use firmware::can_frames::{decode, encode_report, Message, RawFrame, StatusInfo};
use firmware::hub::Hub;
use firmware::pipeline::{ChannelFault, Pipeline, PipelineConfig, Reading};
use firmware::report::{HubState, StatusFlags};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::position::PositionTerm;
use model_core::{Channel, Model, Name, Params, Reference};

fn name(s: &str) -> Name {
    Name::try_from(s).unwrap()
}

fn vec<T: Clone, const N: usize>(items: &[T]) -> heapless::Vec<T, N> {
    heapless::Vec::from_slice(items).unwrap()
}

/// ey_um = poly(y) + (k - k0) y with k = 0.01 (T1 - 20) um/mm, k0 = 0.001,
/// poly = 3 + 0.02 y (a feed axis' error, seed 003's form); dz_um =
/// 5 (T1 - 20) is an ordinary output beside it.
fn pipeline() -> Pipeline {
    let t1 = Channel {
        name: name("T1"),
        reference: Reference::Value(20.0),
    };
    let y = Channel {
        name: name("y_mm"),
        reference: Reference::Absolute,
    };
    let coef = |value| vec(&[Coef { channel: 0, value }]);
    let model = Model {
        inputs: vec(&[t1, y]),
        outputs: vec(&[name("ey_um"), name("dz_um")]),
        dt_s: 0.0,
        params: Params::Linear(Linear {
            outputs: vec(&[
                LinearOutput {
                    output: 0,
                    intercept: 0.0,
                    coef: coef(0.01),
                    position: Some(PositionTerm {
                        channel: 1,
                        poly: vec(&[3.0, 0.02]),
                        k0: 0.001,
                    }),
                },
                LinearOutput {
                    output: 1,
                    intercept: 0.0,
                    coef: coef(5.0),
                    position: None,
                },
            ]),
        }),
        bounds: None,
        five_point: None,
    }
    .validate()
    .unwrap();
    let mut blob = [0u8; 1024];
    let n = model_core::encode(&model, &mut blob).unwrap();
    Pipeline::new(Hub::load(&blob[..n]), PipelineConfig::DEFAULT).unwrap()
}

/// The slope the model gives at T1, um/m.
fn slope_um_per_m(t1: f64) -> f64 {
    (0.01 * (t1 - 20.0) - 0.001) * 1000.0
}

/// The position needs no reading (the hub does not know it: stale is
/// fine); the slope settles at k(T) - k0 in um/m, the positional output's
/// offset at 0 while the ordinary one follows its model, and the SLOPE
/// frame carries it (0.001 um/m resolution).
#[test]
fn slope_settles_at_the_models_thermal_slope() {
    let mut p = pipeline();
    let readings = [Reading::Value(22.0), Reading::Stale];
    let mut r = p.on_sample(&readings);
    for _ in 0..200 {
        r = p.on_sample(&readings);
    }
    assert_eq!(r.state, HubState::Running);
    assert_eq!(r.positional, 0b01);
    assert!((r.slopes_um_per_m[0] - slope_um_per_m(22.0)).abs() < 1e-9);
    assert_eq!(r.slopes_um_per_m[1], 0.0);
    assert_eq!(r.offsets[0], 0.0, "the thermal part at 0 mm");
    assert!((r.offsets[1] - 10.0).abs() < 1e-9, "dz = 5 x 2 K");
    let frames: heapless::Vec<RawFrame, 7> = encode_report(&r, &StatusInfo::default());
    let slope = frames
        .iter()
        .find_map(|f| match decode(f) {
            Ok(Message::Slope(m)) => Some(m),
            _ => None,
        })
        .expect("a SLOPE frame");
    assert_eq!((slope.output, slope.reference_mm), (0, 0.0));
    assert!((slope.slope_um_per_m - slope_um_per_m(22.0)).abs() <= 0.0005);
}

/// A warm-up step moves the slope at most the slew limit scaled to the
/// stroke: 2 um/s at 1 m of travel = 2 um/m per 1 s sample.
#[test]
fn slope_is_slew_limited_at_the_stroke() {
    let mut p = pipeline();
    let mut prev = p.on_sample(&[Reading::Value(20.0), Reading::Stale]);
    let mut limited = 0;
    for _ in 0..100 {
        let r = p.on_sample(&[Reading::Value(25.0), Reading::Stale]);
        let step = r.slopes_um_per_m[0] - prev.slopes_um_per_m[0];
        assert!(step.abs() <= 2.0 + 1e-9, "step {step} um/m");
        limited += usize::from(r.flags.has(StatusFlags::SLEW_LIMITED));
        prev = r;
    }
    assert!(limited >= 20, "the 49 um/m rise takes ~25 limited samples");
    assert!((prev.slopes_um_per_m[0] - slope_um_per_m(25.0)).abs() < 1e-9);
}

/// T1 fails: the slope holds for the hold time (60 samples), then ramps to
/// zero at the ramp rate scaled to the stroke (1 um/s -> 1 um/m per sample).
#[test]
fn slope_holds_then_ramps_to_zero_on_a_sensor_fault() {
    let mut p = pipeline();
    let mut r = p.on_sample(&[Reading::Value(24.0), Reading::Stale]);
    for _ in 0..100 {
        r = p.on_sample(&[Reading::Value(24.0), Reading::Stale]);
    }
    let held = r.slopes_um_per_m[0];
    assert!((held - slope_um_per_m(24.0)).abs() < 1e-9);
    let bad = [Reading::Fault(ChannelFault::Open), Reading::Stale];
    for k in 0..60 {
        let r = p.on_sample(&bad);
        assert_eq!(r.slopes_um_per_m[0], held, "held at fault sample {k}");
        assert!(r.flags.has(StatusFlags::SENSOR_FAULT));
    }
    let mut prev = held;
    let mut n = 0;
    while prev > 0.0 {
        let r = p.on_sample(&bad);
        assert!(prev - r.slopes_um_per_m[0] <= 1.0 + 1e-9);
        assert!(r.slopes_um_per_m[0] <= prev);
        prev = r.slopes_um_per_m[0];
        n += 1;
        assert!(n < 1000, "ramp never ended");
    }
    assert_eq!(n, held.ceil() as usize, "1 um/m per sample from {held}");
    assert_eq!(p.on_sample(&bad).state, HubState::Zeroed);
}

/// The axis position from the CNC (TOOL_POSITION frame) reaches the
/// position input through `cnc_inputs::gather`, but the offsets and slope
/// do not depend on it: the CNC applies the slope at its own position. So
/// the frames stopping (position stale) changes nothing either.
#[test]
fn a_received_position_is_gathered_but_does_not_move_the_offsets() {
    use firmware::can_rx::{encode_tool_position, ToolPosition};
    use firmware::cnc_inputs::{gather, CncInputs};
    let (mut with, mut without) = (pipeline(), pipeline());
    let mut cnc = CncInputs::new(5_000);
    let frame: RawFrame = encode_tool_position(&ToolPosition {
        tool_mm: None,
        position_mm: Some(450.0),
    })
    .unwrap();
    cnc.on_frame(&frame, 0).unwrap();
    for s in 0..20u32 {
        let now_ms = s * 1_000;
        let (r, _) = gather(with.hub(), &cnc, now_ms, |_| Reading::Value(22.0));
        let want = if s <= 5 {
            Reading::Direct(450.0)
        } else {
            Reading::Stale
        };
        assert_eq!(r[1], want, "sample {s}");
        let a = with.on_sample(&r[..2]);
        let b = without.on_sample(&[Reading::Value(22.0), Reading::Stale]);
        assert_eq!(a, b, "sample {s}");
        assert_eq!(a.faulty_channels, 0);
    }
}
