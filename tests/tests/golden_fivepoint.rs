//! Five-point compensation goldens: a five-point model written as a spec,
//! through the blob, turned into tool-tip offsets; and `fivepoint` on probe
//! readings at the magnitudes seed 001 reports.
//!
//! Seeds 000 and 001 print the compensation equations (seed 001 Eq. 1-4,
//! 25-28 and 36; seed 000 Eq. 21-27) but no worked numeric example of them
//! (their figures give only magnitudes: a = 120 mm, E up to 39.6 um, a
//! radial offset up to 35 um in X). The cases below are derived by hand,
//! each chosen so that the exact answer has a short closed form.

use host_tools::data::cells::Cells;
use host_tools::fivepoint::{compute, FivePointParams, ProbeRun};
use model_core::geometry::{GeometryError, SpindleDrift};
use model_core::ValidModel;
use thermcomp_tests::isclose;

fn through_blob(spec: &str) -> ValidModel {
    let model = host_tools::data::spec::parse("fivepoint.toml", spec).expect("spec builds");
    let blob = model_core::blob::encode_to_vec(&model).expect("encodes");
    model_core::decode(&blob).expect("decodes")
}

/// A constant five-point model at seed 001's magnitudes, written as a spec
/// and read back from its blob: E = 39.6 um, theta_x = 100 urad,
/// theta_y = -50 urad, l_defl = 300 mm, a 50 mm tool (L = 350 000 um). By
/// hand, with tan t = t (1 + t^2/3) and q = 1 + 6.25e-9:
///   dx = (L + E) tan(1e-4) / q  = 35.003 96 (1 + 3.33e-9 - 6.25e-9)  = 35.003 959 90 um
///   dy = -(L + E) tan(5e-5) / q = -17.501 98 (1 + 0.83e-9 - 6.25e-9) = -17.501 979 91 um
///   dz = L t^2 / (q (q + 1)) - E / q = 2.1875e-3 - 39.599 999 75     = -39.597 812 25 um
/// 1e-7 um covers the 8-digit hand rounding.
#[test]
fn five_point_spec_through_the_blob_at_seed_001_magnitudes() {
    let eq = |o: &str, v: f64| {
        format!("[[linear]]\noutput = \"{o}\"\nintercept = {v:?}\ncoef = {{ T1 = 0.0 }}\n")
    };
    let spec = format!(
        "kind = \"linear\"\nl_defl_mm = 300.0\n{}{}{}",
        eq("e_um", 39.6),
        eq("theta_x_urad", 100.0),
        eq("theta_y_urad", -50.0)
    );
    let model = through_blob(&spec);
    let tip = model.five_point().expect("a five-point model");
    assert_eq!(tip.l_defl_mm(), 300.0);
    let [dx, dy, dz] = tip.tool_tip(&[39.6, 100.0, -50.0], 50.0).unwrap();
    assert!(isclose(dx, 35.003_959_90, 0.0, 1e-7), "{dx}");
    assert!(isclose(dy, -17.501_979_91, 0.0, 1e-7), "{dy}");
    assert!(isclose(dz, -39.597_812_25, 0.0, 1e-7), "{dz}");
}

/// A 3-4-5 tilt (tan = 3/4, cos = 4/5), E = 10 um, l_defl = 300 mm, a
/// 100 mm tool (L = 400 000 um). By hand:
///   dx = (L + E) tan / q = 400 010 x 3/5 = 240 006 um
///   dz = L - (L + E) cos = 400 000 - 320 008 = 79 992 um.
/// Not a thermal angle: it checks the exact geometry, where the small-angle
/// rule would be off by 80 mm (1e-9 relative covers atan/tan rounding).
/// The hub's path refuses it: tilts beyond 10 mrad are a model fault there.
#[test]
fn exact_geometry_of_a_3_4_5_tilt() {
    let d = SpindleDrift {
        elongation_um: 10.0,
        yaw_rad: 0.75f64.atan(),
        pitch_rad: 0.0,
    };
    let t = d.tool_tip_drift(300.0, 100.0).unwrap();
    assert!(isclose(t.x_um, 240_006.0, 1e-9, 0.0), "{}", t.x_um);
    assert_eq!(t.y_um, 0.0);
    assert!(isclose(t.z_um, 79_992.0, 1e-9, 0.0), "{}", t.z_um);
    let spec = "kind = \"linear\"\nl_defl_mm = 300.0\n".to_string()
        + &["e_um", "theta_x_urad", "theta_y_urad"]
            .map(|o| {
                format!("[[linear]]\noutput = \"{o}\"\nintercept = 0.0\ncoef = {{ T1 = 1.0 }}\n")
            })
            .concat();
    let hub = through_blob(&spec);
    let tip = hub.five_point().unwrap();
    assert_eq!(
        tip.tool_tip(&[10.0, 0.75f64.atan() * 1e6, 0.0], 100.0),
        Err(GeometryError::AngleOutOfRange)
    );
}

/// Probe changes at seed 001's magnitudes, a = 120 mm: S1 - S3 = 12 um
/// (theta_x = atan(1e-4)), S2 - S4 = -6 um (theta_y = atan(-5e-5)),
/// S5 = 39.6 um (seed 001's largest elongation). With l_defl = 300 mm and a
/// 50 mm tool, L = 350 000 um, q = sqrt(1 + 1.25e-8), by hand
///   dx = (L + E) 1e-4 / q  = 35.003 96 (1 - 6.25e-9)  = 35.003 959 78 um
///   dy = -(L + E) 5e-5 / q = -17.501 98 (1 - 6.25e-9) = -17.501 979 89 um
///   dz = L t^2 / (q (q + 1)) - E / q = 2.1875e-3 - 39.6 (1 - 6.25e-9)
///      = -39.597 812 25 um
/// (dx ~ 35 um: seed 001's largest X offset). 1e-7 um covers the f64
/// rounding of the atan/tan round trip; the readings' cold values are
/// arbitrary and cancel.
#[test]
fn fivepoint_at_seed_001_magnitudes() {
    let cold = [1503.0, 987.0, 1490.0, 1011.0, 2040.0];
    let warm = [1503.0 + 12.0, 987.0 - 6.0, 1490.0, 1011.0, 2040.0 + 39.6];
    let col = |i: usize| vec![cold[i], warm[i]];
    let cols: Vec<Vec<f64>> = (0..5).map(col).collect();
    let probes = [0, 1, 2, 3, 4].map(|i| Cells::new(&cols[i]));
    let run = ProbeRun {
        t_s: &[0.0, 60.0],
        probes,
        tool_mm: None,
    };
    let params = FivePointParams {
        a_mm: 120.0,
        l_defl_mm: 300.0,
        tool_mm: Some(50.0),
    }
    .check()
    .unwrap();
    let (c, o) = compute(&params, &run).unwrap();
    let at = |k: usize| c.columns[k][1].unwrap();
    assert!(isclose(at(0), 39.6, 0.0, 1e-9), "E {}", at(0));
    assert!(isclose(at(1), 1e6 * 1e-4f64.atan(), 0.0, 1e-9));
    assert!(isclose(at(2), 1e6 * (-5e-5f64).atan(), 0.0, 1e-9));
    assert!(isclose(at(3), 35.003_959_78, 0.0, 1e-7), "dx {}", at(3));
    assert!(isclose(at(4), -17.501_979_89, 0.0, 1e-7), "dy {}", at(4));
    assert!(isclose(at(5), -39.597_812_25, 0.0, 1e-7), "dz {}", at(5));
    // The cold row is the reference: all zero.
    assert!(c.columns.iter().all(|col| col[0] == Some(0.0)));
    assert_eq!(o.tip_rows, 2);
}

/// A spec with the five-point outputs must say where the deflection centre
/// is, and only such a spec may.
#[test]
fn specs_need_l_defl_exactly_for_five_point_outputs() {
    let eq =
        |o: &str| format!("[[linear]]\noutput = \"{o}\"\nintercept = 0.0\ncoef = {{ T1 = 1.0 }}\n");
    let body = ["e_um", "theta_x_urad", "theta_y_urad"].map(eq).concat();
    let e = host_tools::data::spec::parse("s.toml", &format!("kind = \"linear\"\n{body}"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("s.toml:1:8") && e.contains("l_defl_mm"), "{e}");
    let dz = format!("kind = \"linear\"\nl_defl_mm = 300.0\n{}", eq("dz_um"));
    let e = host_tools::data::spec::parse("s.toml", &dz)
        .unwrap_err()
        .to_string();
    assert!(e.contains("five-point models only"), "{e}");
}
