//! Golden tests for the five-point spindle geometry: hand-checked drifts and
//! the papers' small-angle compensation rules.

use model_core::geometry::{
    spindle_drift, GeometryError, ProbeReadings, SpindleDrift, ToolTipDrift,
};
use proptest::prelude::*;

/// Probe spacing in both papers.
const A_MM: f64 = 120.0;
/// Deflection centre above the nose used in the hand calculations.
const L_DEFL_MM: f64 = 300.0;

fn changes(s1: f64, s2: f64, s3: f64, s4: f64, s5: f64) -> ProbeReadings {
    ProbeReadings {
        s1_um: s1,
        s2_um: s2,
        s3_um: s3,
        s4_um: s4,
        s5_um: s5,
    }
}

fn drift_of(c: &ProbeReadings) -> SpindleDrift {
    spindle_drift(c, A_MM).unwrap_or_else(|e| panic!("{e}"))
}

fn tip(d: &SpindleDrift, tool_mm: f64) -> ToolTipDrift {
    d.tool_tip_drift(L_DEFL_MM, tool_mm)
        .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn pure_elongation_for_any_tool_length() {
    let d = drift_of(&changes(0.0, 0.0, 0.0, 0.0, 20.0));
    // Zero tilt makes every term a product by exactly 0 or 1: exact.
    assert_eq!((d.elongation_um, d.yaw_rad, d.pitch_rad), (20.0, 0.0, 0.0));
    for tool_mm in [0.0, 50.0, 100.0, 237.5] {
        let t = tip(&d, tool_mm);
        assert_eq!(
            (t.x_um, t.y_um, t.z_um),
            (0.0, 0.0, -20.0),
            "tool {tool_mm} mm"
        );
        let off = d
            .compensation_offsets(L_DEFL_MM, tool_mm)
            .unwrap_or_else(|e| panic!("{e}"));
        // 0.0 negated is −0.0, which compares equal to 0.0.
        assert_eq!((off.x_um, off.y_um, off.z_um), (0.0, 0.0, 20.0));
    }
}

#[test]
fn pure_yaw_from_raw_readings() {
    // Cold and warm raw readings; only S1 moves, by +12 µm.
    let cold = changes(1503.0, 987.0, 1490.0, 1011.0, 2040.0);
    let warm = changes(1515.0, 987.0, 1490.0, 1011.0, 2040.0);
    let d = drift_of(&warm.change_from(&cold));
    // θx = atan(12 µm / 120 000 µm) = atan(1e-4); 1e-18 rad is ~70 ulps of
    // 1e-4, room for the division and atan roundings only.
    let theta = 1e-4_f64.atan();
    assert!((d.yaw_rad - theta).abs() < 1e-18, "{}", d.yaw_rad);
    assert_eq!((d.elongation_um, d.pitch_rad), (0.0, 0.0));

    let t = tip(&d, 100.0);
    // dx = 400 000 µm · sin θ = 39.99999980000000 µm. Reference by sin(),
    // independent of the code's tan/√ form; 1e-11 µm is ~1e-12 relative.
    let l_um = 400_000.0;
    let x_ref = l_um * theta.sin();
    assert!((t.x_um - x_ref).abs() < 1e-11, "{} vs {x_ref}", t.x_um);
    assert!((t.x_um - 39.999_999_8).abs() < 1e-9, "{}", t.x_um);
    // dz = L (1 − cos θ) > 0: the tilt lifts the tip. 1 − cos θ = 2 sin²(θ/2)
    // avoids cancellation in the reference; 1e-14 µm is ~5e-12 relative of
    // 0.002 µm. The brief's 0.002 µm is good to its 1.5e-11 µm truncation.
    let z_ref = l_um * 2.0 * (theta / 2.0).sin().powi(2);
    assert!((t.z_um - z_ref).abs() < 1e-14, "{} vs {z_ref}", t.z_um);
    assert!((t.z_um - 0.002).abs() < 2e-11, "{}", t.z_um);
    assert_eq!(t.y_um, 0.0);
}

#[test]
fn pure_pitch_mirrors_pure_yaw() {
    let yaw = tip(&drift_of(&changes(12.0, 0.0, 0.0, 0.0, 0.0)), 100.0);
    let pitch_drift = drift_of(&changes(0.0, 12.0, 0.0, 0.0, 0.0));
    assert_eq!((pitch_drift.yaw_rad, pitch_drift.elongation_um), (0.0, 0.0));
    let pitch = tip(&pitch_drift, 100.0);
    // The formulas are symmetric in X and Y, so the results are bit-equal.
    assert_eq!(
        (pitch.x_um, pitch.y_um, pitch.z_um),
        (0.0, yaw.x_um, yaw.z_um)
    );
}

#[test]
fn far_probe_moving_more_tilts_the_other_way() {
    let d = drift_of(&changes(0.0, 0.0, 12.0, 0.0, 0.0));
    assert!((d.yaw_rad + 1e-4_f64.atan()).abs() < 1e-18, "{}", d.yaw_rad);
    assert!(tip(&d, 100.0).x_um < 0.0);
}

#[test]
fn tool_length_changes_dx_not_dz() {
    // E = 20 µm, θx = atan(1e-4), θy = atan(−5e-5); tool 100 → 150 mm.
    let d = drift_of(&changes(12.0, -6.0, 0.0, 0.0, 20.0));
    let short = tip(&d, 100.0);
    let long = tip(&d, 150.0);
    let delta_tool_um = 50_000.0;

    // Exact geometry: Δdx = Δtool · tan θx / q. The papers' rule is
    // Δdx ≈ Δtool · θx; they differ by O(Δtool·θ³) ≈ 5e-8 µm, so 1e-6 µm.
    let ddx = long.x_um - short.x_um;
    let ddy = long.y_um - short.y_um;
    assert!((ddx - delta_tool_um * d.yaw_rad).abs() < 1e-6, "{ddx}");
    assert!((ddy - delta_tool_um * d.pitch_rad).abs() < 1e-6, "{ddy}");
    assert!((ddx - 5.0).abs() < 1e-6, "{ddx}"); // 50 mm × 1e-4 rad = 5 µm

    // Δdz = Δtool·(1 − cos θ) ≈ 50 000 · 6.25e-9 = 3.1e-4 µm: not exactly
    // zero, but 300× below a CNC's 0.1 µm resolution, so 1e-3 µm bounds
    // "independent of the tool length".
    let ddz = long.z_um - short.z_um;
    assert!(ddz.abs() < 1e-3, "{ddz}");
    // And dz ≈ −E for both tools: the residue is L·θ²/2 ≤ 3 nm.
    for t in [short, long] {
        assert!((t.z_um + 20.0).abs() < 5e-3, "{}", t.z_um);
    }
}

#[test]
fn offsets_cancel_the_drift() {
    let d = drift_of(&changes(9.0, -4.0, 2.0, 1.0, 31.0));
    let t = tip(&d, 120.0);
    let off = d
        .compensation_offsets(L_DEFL_MM, 120.0)
        .unwrap_or_else(|e| panic!("{e}"));
    // Negation is exact.
    assert_eq!(
        (t.x_um + off.x_um, t.y_um + off.y_um, t.z_um + off.z_um),
        (0.0, 0.0, 0.0)
    );
    assert_eq!(t.compensation(), off);
}

#[test]
fn bad_spacing_is_rejected() {
    let c = changes(12.0, 0.0, 0.0, 0.0, 20.0);
    for a_mm in [
        0.0,
        -0.0,
        -120.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ] {
        assert_eq!(
            spindle_drift(&c, a_mm),
            Err(GeometryError::InvalidSpacing),
            "{a_mm}"
        );
    }
    for bad in [f64::NAN, f64::INFINITY] {
        let c = changes(bad, 0.0, 0.0, 0.0, 0.0);
        assert_eq!(
            spindle_drift(&c, A_MM),
            Err(GeometryError::NonFiniteReading)
        );
    }
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        proptest::num::f64::ANY,
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(0.0),
        Just(f64::MAX),
        Just(core::f64::consts::FRAC_PI_2),
        -500.0..500.0f64,
    ]
}

proptest! {
    #[test]
    fn no_public_function_panics(
        s in (any_f64(), any_f64(), any_f64(), any_f64(), any_f64()),
        r in (any_f64(), any_f64(), any_f64(), any_f64(), any_f64()),
        a_mm in any_f64(),
        l_defl_mm in any_f64(),
        tool_mm in any_f64(),
        raw in (any_f64(), any_f64(), any_f64()),
    ) {
        let warm = changes(s.0, s.1, s.2, s.3, s.4);
        let cold = changes(r.0, r.1, r.2, r.3, r.4);
        let hand_built = SpindleDrift { elongation_um: raw.0, yaw_rad: raw.1, pitch_rad: raw.2 };
        let computed = spindle_drift(&warm.change_from(&cold), a_mm);
        if let Ok(d) = computed {
            prop_assert!(d.elongation_um.is_finite());
            prop_assert!(d.yaw_rad.abs() <= core::f64::consts::FRAC_PI_2);
            prop_assert!(d.pitch_rad.abs() <= core::f64::consts::FRAC_PI_2);
        }
        for d in [computed.ok(), Some(hand_built)].into_iter().flatten() {
            if let Ok(t) = d.tool_tip_drift(l_defl_mm, tool_mm) {
                prop_assert!(t.x_um.is_finite() && t.y_um.is_finite() && t.z_um.is_finite());
                let off = d.compensation_offsets(l_defl_mm, tool_mm);
                prop_assert_eq!(off, Ok(t.compensation()));
            }
        }
    }
}
