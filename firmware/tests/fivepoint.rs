//! Five-point models on the hub: the model's E, θx, θy become the tool-tip
//! offsets dx, dy, dz with the tool length last set, every sample, and a
//! tool change moves dx and dy by Δtool·θ at the next sample.
#![cfg(feature = "model")]

use firmware::hub::Hub;
use firmware::pipeline::{Pipeline, PipelineConfig, Reading};
use firmware::report::{HubState, Report, StatusFlags};
use model_core::fivepoint::FivePoint;
use model_core::geometry::SpindleDrift;
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::{Channel, Model, Name, Params, Reference};

fn name(s: &str) -> Name {
    Name::try_from(s).unwrap()
}

fn vec<T: Clone, const N: usize>(items: &[T]) -> heapless::Vec<T, N> {
    heapless::Vec::from_slice(items).unwrap()
}

const L_DEFL_MM: f64 = 300.0;

/// Outputs in a shuffled order: theta_y_urad = -1 (T1 - 20),
/// e_um = 10 (T1 - 20), theta_x_urad = 2 (T1 - 20).
fn pipeline() -> Pipeline {
    let t1 = Channel {
        name: name("T1"),
        reference: Reference::Value(20.0),
    };
    let eq = |output, value| LinearOutput {
        output,
        intercept: 0.0,
        coef: vec(&[Coef { channel: 0, value }]),
        position: None,
    };
    let model = Model {
        inputs: vec(&[t1]),
        outputs: vec(&[name("theta_y_urad"), name("e_um"), name("theta_x_urad")]),
        dt_s: 0.0,
        params: Params::Linear(Linear {
            outputs: vec(&[eq(0, -1.0), eq(1, 10.0), eq(2, 2.0)]),
        }),
        bounds: None,
        five_point: Some(FivePoint {
            l_defl_mm: L_DEFL_MM,
        }),
    };
    Pipeline::new(hub(&model.validate().unwrap()), PipelineConfig::DEFAULT).unwrap()
}

/// A hub running `model`, loaded from its blob as the board loads one.
fn hub(model: &model_core::ValidModel) -> Hub {
    let mut blob = [0u8; 4096];
    let n = model_core::encode(model, &mut blob).unwrap();
    Hub::load(&blob[..n])
}

/// The exact tip drift for E = 10 µm, θx = 2 µrad, θy = -1 µrad.
fn expected(tool_mm: f64) -> [f64; 3] {
    let d = SpindleDrift {
        elongation_um: 10.0,
        yaw_rad: 2e-6,
        pitch_rad: -1e-6,
    };
    let t = d.tool_tip_drift(L_DEFL_MM, tool_mm).unwrap();
    [t.x_um, t.y_um, t.z_um]
}

fn run(p: &mut Pipeline, samples: usize) -> Report {
    let mut last = None;
    for _ in 0..samples {
        last = Some(p.on_sample(&[Reading::Value(21.0)]));
    }
    last.unwrap()
}

#[test]
fn lanes_are_dx_dy_dz_and_follow_tool_changes() {
    let mut p = pipeline();
    // No tool length yet: dx, dy held at zero (stale), dz follows -E
    // through the 2 um/s slew limit (10 um: 5 samples at 1 s).
    let r = run(&mut p, 8);
    assert!(r.flags.has(StatusFlags::STALE));
    assert_eq!(r.n_outputs, 3);
    assert_eq!((r.offsets[0], r.offsets[1]), (0.0, 0.0));
    // Tool 0 for dz before the first length: exact here, L = l_defl only.
    let [_, _, dz0] = expected(0.0);
    assert!((r.offsets[2] - dz0).abs() < 1e-12, "{}", r.offsets[2]);
    assert!((dz0 + 10.0).abs() < 1e-3, "dz ~ -E");

    // First tool length: dx ~ (300 + 100) mm * 2 urad = 0.8 um.
    // Every step below is under one sample's slew (2 um): reached at once.
    let mut prev: Option<(f64, f64, f64)> = None;
    for tool_mm in [100.0, 250.0, 50.0, 400.0] {
        p.set_tool_length_mm(tool_mm).unwrap();
        let r = p.on_sample(&[Reading::Value(21.0)]);
        assert_eq!(r.state, HubState::Running, "tool {tool_mm}");
        assert!(!r.flags.has(StatusFlags::SLEW_LIMITED));
        let want = expected(tool_mm);
        for (k, w) in want.iter().enumerate() {
            // 1e-12 um: the same f64 geometry on both sides.
            assert!((r.offsets[k] - w).abs() < 1e-12, "tool {tool_mm} lane {k}");
        }
        // Small-angle check of the papers' rule: dx = (l + tool) theta_x
        // within 0.1 um (the exact term adds E theta ~ 2e-5 um).
        let l_um = (L_DEFL_MM + tool_mm) * 1e3;
        assert!((r.offsets[0] - l_um * 2e-6).abs() < 0.1);
        assert!((r.offsets[1] + l_um * 1e-6).abs() < 0.1);
        if let Some((t0, dx0, dy0)) = prev {
            // The change in dx and dy at the tool change is delta_tool * theta.
            let dt_um = (tool_mm - t0) * 1e3;
            assert!((r.offsets[0] - dx0 - dt_um * 2e-6).abs() < 1e-6);
            assert!((r.offsets[1] - dy0 + dt_um * 1e-6).abs() < 1e-6);
        }
        prev = Some((tool_mm, r.offsets[0], r.offsets[1]));
    }
}

#[test]
fn swap_carries_lanes_by_tip_name() {
    let mut p = pipeline();
    p.set_tool_length_mm(100.0).unwrap();
    let before = run(&mut p, 10);
    p.swap_model(&mut hub(pipeline().hub().model().unwrap()))
        .unwrap();
    assert_eq!(p.offsets_um(), before.offsets, "no jump at a swap");
}
