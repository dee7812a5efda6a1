//! Five-point models in the blob (format 3): the geometry's exact bytes,
//! round trips, older formats, and what validation refuses.

mod common;

use common::{chan, hv, outputs};
use model_core::blob::{self, crc32, HEADER_LEN, MAGIC, MAX_BLOB_LEN};
use model_core::fivepoint::{FivePoint, MAX_L_DEFL_MM};
use model_core::linear::{Coef, Linear, LinearOutput};
use model_core::{decode, BlobError, Model, ModelError, Params, Reference};

/// e_um = 2 + 0.5 T1, theta_x_urad = 0.25 T1, theta_y_urad = -0.125 T1
/// (T1 from its first sample): made up, exactly representable.
fn five_point(l_defl_mm: Option<f64>) -> Model {
    let eq = |output, intercept, value| LinearOutput {
        output,
        intercept,
        coef: hv(&[Coef { channel: 0, value }]),
        position: None,
    };
    Model {
        inputs: hv(&[chan("T1", Reference::First)]),
        outputs: outputs(&["e_um", "theta_x_urad", "theta_y_urad"]),
        dt_s: 0.0,
        params: Params::Linear(Linear {
            outputs: hv(&[eq(0, 2.0, 0.5), eq(1, 0.0, 0.25), eq(2, 0.0, -0.125)]),
        }),
        bounds: None,
        five_point: l_defl_mm.map(|l_defl_mm| FivePoint { l_defl_mm }),
    }
}

fn frame(version: u16, body: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&[2, 0]);
    out.extend_from_slice(&u32::try_from(body.len()).unwrap().to_le_bytes());
    out.extend_from_slice(body);
    let crc = crc32(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

fn blob_of(model: Model) -> Vec<u8> {
    let mut buf = [0u8; MAX_BLOB_LEN];
    let n = blob::encode(&model.validate().unwrap(), &mut buf).unwrap();
    buf[..n].to_vec()
}

/// Body length by hand (postcard): inputs 1 + ("T1" 1+2, First 1) = 5;
/// outputs 1 + (1+4) + (1+12) + (1+12) = 32; dt_s 8; params: tag 1 +
/// count 1 + three equations of (output 1, intercept 8, coef count 1,
/// channel 1, value 8, position None 1) = 20 each, 60 -> 62; bounds None 1;
/// five_point Some 1 + l_defl_mm 8 = 9. Total 117 = 0x75.
#[test]
fn geometry_bytes_are_frozen() {
    let blob = blob_of(five_point(Some(312.5)));
    assert_eq!(
        blob[..HEADER_LEN],
        [b'T', b'C', b'M', b'B', 3, 0, 2, 0, 0x75, 0, 0, 0]
    );
    assert_eq!(blob.len(), HEADER_LEN + 117 + 4);
    let tail = &blob[blob.len() - 4 - 10..blob.len() - 4];
    assert_eq!(tail[0], 0, "bounds: None");
    assert_eq!(tail[1], 1, "five_point: Some");
    assert_eq!(tail[2..], 312.5f64.to_le_bytes(), "l_defl_mm");
    let back = decode(&blob).unwrap();
    assert_eq!(back.model(), &five_point(Some(312.5)));
    assert_eq!(back.five_point().map(|t| t.l_defl_mm()), Some(312.5));
    // Tip axes X, Y, Z come from theta_x (1), theta_y (2), e (0).
    assert_eq!(
        back.five_point().map(|t| t.source_outputs()),
        Some([1, 2, 0])
    );
}

/// A version-2 blob of the same outputs (written before format 3) decodes
/// as an ordinary model: no geometry, so the hub sends its outputs as they
/// are, as that firmware did.
#[test]
fn version_2_five_point_names_decode_without_geometry() {
    let v3 = blob_of(five_point(None));
    let v2 = frame(2, &v3[HEADER_LEN..v3.len() - 5]);
    let back = decode(&v2).unwrap();
    assert!(back.five_point().is_none());
    assert_eq!(back.model(), &five_point(None));
}

#[test]
fn validation_refuses_bad_geometry() {
    for l in [-0.5, f64::NAN, MAX_L_DEFL_MM * 2.0] {
        assert_eq!(
            five_point(Some(l)).validate().unwrap_err(),
            ModelError::BadFivePoint,
            "{l}"
        );
    }
    // Geometry on a model that does not output the three angles.
    let mut dz = five_point(Some(300.0));
    dz.outputs = outputs(&["e_um", "theta_x_urad", "dz_um"]);
    assert_eq!(dz.validate().unwrap_err(), ModelError::BadFivePoint);
    // And the same refused by decode when a hostile encoder framed it.
    let mut bad = five_point(Some(-1.0));
    bad.five_point = Some(FivePoint { l_defl_mm: -1.0 });
    let mut buf = [0u8; MAX_BLOB_LEN];
    let body = postcard::to_slice(&bad, &mut buf).unwrap();
    assert_eq!(
        decode(&frame(3, body)).unwrap_err(),
        BlobError::Invalid(ModelError::BadFivePoint)
    );
}
