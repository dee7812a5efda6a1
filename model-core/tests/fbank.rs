//! The filter-bank kind and the calibration bounds: a case worked by hand,
//! the bank against the TF path it is a special case of, blob versions, and
//! the extrapolation measure.

mod common;

use common::{chan, fbank_3x2, fbank_sized, fbank_wide, hv, outputs};
use model_core::blob::{self, crc32, HEADER_LEN, MAGIC, MAX_BLOB_LEN};
use model_core::fbank::{FbOutput, Feature, FilterBank};
use model_core::model::EXTRAPOLATION_FLAG_AT;
use model_core::tf::TfEntry;
use model_core::{decode, Model, ModelKind, ModelState, Params, Reference, Span, ValidModel};

fn blob_of(model: &ValidModel) -> Vec<u8> {
    let mut buf = [0u8; MAX_BLOB_LEN];
    let n = blob::encode(model, &mut buf).expect("encodes");
    buf[..n].to_vec()
}

/// Frames `body` as a blob of format `version`, as docs/blob-format.md says.
fn frame(version: u16, kind_code: u8, body: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    out.push(kind_code);
    out.push(0);
    out.extend_from_slice(&u32::try_from(body.len()).unwrap().to_le_bytes());
    out.extend_from_slice(body);
    let crc = crc32(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

fn feature(input: u8, power: u8, tau_s: f64) -> Feature {
    Feature {
        input,
        power,
        tau_s,
    }
}

/// A filter bank over `inputs` at `dt_s` without bounds: output `j`
/// (`names[j]`) is `coefs[j]` over `features`, without intercept.
fn bank(
    inputs: &[model_core::Channel],
    names: &[&str],
    dt_s: f64,
    features: &[Feature],
    coefs: &[&[f64]],
) -> ValidModel {
    Model {
        inputs: hv(inputs),
        outputs: outputs(names),
        dt_s,
        params: Params::Fbank(FilterBank {
            features: hv(features),
            outputs: coefs
                .iter()
                .enumerate()
                .map(|(j, c)| FbOutput {
                    output: j as u8,
                    intercept: 0.0,
                    coef: hv(c),
                })
                .collect(),
        }),
        bounds: None,
        five_point: None,
    }
    .validate()
    .unwrap()
}

/// Two inputs (T1 relative to its first sample, T2 absolute), three
/// features: T1 raw, T1 low-passed with pole 1/2, T2 squared;
/// `y = 1 + 2 s1 + 4 s2 + 0.5 s3`.
fn hand_model() -> ValidModel {
    let dt_s = 1.0;
    // exp(-dt / tau) = 1/2.
    let tau_s = dt_s / std::f64::consts::LN_2;
    Model {
        inputs: hv(&[
            chan("T1", Reference::First),
            chan("T2", Reference::Absolute),
        ]),
        outputs: outputs(&["dz_um"]),
        dt_s,
        params: Params::Fbank(FilterBank {
            features: hv(&[feature(0, 1, 0.0), feature(0, 1, tau_s), feature(1, 2, 0.0)]),
            outputs: hv(&[FbOutput {
                output: 0,
                intercept: 1.0,
                coef: hv(&[2.0, 4.0, 0.5]),
            }]),
        }),
        bounds: None,
        five_point: None,
    }
    .validate()
    .expect("valid")
}

/// Worked by hand (T1 first sample 20):
///
/// | k | T1, T2 | x1 | s1 | s2 = s2/2 + x1/2 | s3 = T2^2 | y |
/// |---|---|---|---|---|---|---|
/// | 0 | 20, 3  |  0 |  0 | 0 (first: s = v) | 9 | 1 + 0 + 0 + 4.5 = 5.5 |
/// | 1 | 22, 1  |  2 |  2 | 1                | 1 | 1 + 4 + 4 + 0.5 = 9.5 |
/// | 2 | 22, -2 |  2 |  2 | 1.5              | 4 | 1 + 4 + 6 + 2 = 13 |
/// | 3 | 18, 0  | -2 | -2 | -0.25            | 0 | 1 - 4 - 1 + 0 = -4 |
///
/// Every value is exact in binary; the only rounding is the pole,
/// `exp(-ln 2)`, within an ulp or two of 1/2, so 1e-14 absolute.
#[test]
fn tiny_case_worked_by_hand() {
    let vm = hand_model();
    assert_eq!(vm.kind(), ModelKind::Fbank);
    assert!((vm.fbank_poles()[1] - 0.5).abs() < 1e-15);
    assert_eq!(vm.fbank_poles()[0], 0.0);
    let mut state = ModelState::new();
    for (x, expected) in [
        ([20.0, 3.0], 5.5),
        ([22.0, 1.0], 9.5),
        ([22.0, -2.0], 13.0),
        ([18.0, 0.0], -4.0),
    ] {
        let mut y = [0.0];
        vm.step(&mut state, &x, &mut y).unwrap();
        assert!(
            (y[0] - expected).abs() < 1e-14,
            "{x:?}: {} vs {expected}",
            y[0]
        );
    }
}

/// A filtered feature with weight `c` is the TF `c (1 - p) / (1 - p q)`:
/// both kinds, fed the same few hundred random samples, agree to 1e-12 of
/// the output's scale. They round differently (`c (p s + (1 - p) v)`
/// against `c (1 - p) u + p y`), and a pole at 0.951 keeps about 20 past
/// roundings of ~1e-16 each alive, so 1e-12 leaves a wide margin while any
/// real difference (a wrong start, an off-by-one step) is of order 1.
#[test]
fn one_filtered_feature_equals_a_first_order_tf() {
    for (reference, power_on) in [(Reference::First, false), (Reference::Value(20.0), true)] {
        let c = 2.5;
        let (dt_s, tau_s) = (30.0, 600.0);
        let fb = Model {
            inputs: hv(&[chan("T1", reference)]),
            outputs: outputs(&["dz_um"]),
            dt_s,
            params: Params::Fbank(FilterBank {
                features: hv(&[feature(0, 1, tau_s)]),
                outputs: hv(&[FbOutput {
                    output: 0,
                    intercept: 0.0,
                    coef: hv(&[c]),
                }]),
            }),
            bounds: None,
            five_point: None,
        }
        .validate()
        .unwrap();
        let p = fb.fbank_poles()[0];
        assert!((p - (-0.05f64).exp()).abs() < 1e-15);
        let tf = Model {
            params: Params::Tf(hv(&[TfEntry {
                output: 0,
                input: 0,
                a: hv(&[c * (1.0 - p)]),
                b: hv(&[1.0, -p]),
            }])),
            ..fb.model().clone()
        }
        .validate()
        .unwrap();
        let (mut s_fb, mut s_tf) = (ModelState::new(), ModelState::new());
        // SplitMix64-style generator: a random walk of temperatures.
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = seed;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            (z ^ (z >> 31)) as f64 / u64::MAX as f64 - 0.5
        };
        let mut t = 23.0;
        let mut scale = 1.0f64;
        for k in 0..400 {
            t += if power_on { 2.0 } else { 0.5 } * next();
            let (mut a, mut b) = ([0.0], [0.0]);
            fb.step(&mut s_fb, &[t], &mut a).unwrap();
            tf.step(&mut s_tf, &[t], &mut b).unwrap();
            scale = scale.max(b[0].abs());
            assert!(
                (a[0] - b[0]).abs() <= 1e-12 * scale,
                "step {k}: fbank {} tf {}",
                a[0],
                b[0]
            );
        }
    }
}

#[test]
fn blob_round_trip_keeps_bounds_and_poles() {
    let vm = fbank_3x2(true).validate().unwrap();
    let bytes = blob_of(&vm);
    assert_eq!(bytes[4..7], [3, 0, 6], "format 3, kind code 6");
    let back = decode(&bytes).unwrap();
    assert_eq!(back.model(), vm.model());
    assert_eq!(back.bounds(), fbank_3x2(true).bounds.as_ref());
    assert_eq!(back.fbank_poles(), vm.fbank_poles());
    // exp(-30 / 600) = 0.951229424500714 (Python math.exp), to libm's rounding.
    assert!((back.fbank_poles()[1] - 0.951_229_424_500_714).abs() < 1e-15);
    // A bank of 32 x 4 features, one output, fits a blob easily.
    let wide = blob_of(&fbank_wide(32).validate().unwrap());
    assert!(wide.len() < 4096, "{} bytes", wide.len());
    assert_eq!(decode(&wide).unwrap().model(), &fbank_wide(32));
}

/// The largest bank model-core takes (32 inputs x 8 = `MAX_FB_FEATURES`
/// features, `MAX_OUTPUTS` outputs, with bounds) fits the largest blob: 4 x
/// 256 f64 weights are 8 KiB of the 16.
#[test]
fn the_largest_bank_fits_a_blob() {
    use model_core::fbank::MAX_FB_FEATURES;
    use model_core::model::{Bounds, Span, MAX_CHANNELS, MAX_OUTPUTS};
    let taus = [
        0.0,
        300.0,
        900.0,
        2700.0,
        8100.0,
        24_300.0,
        72_900.0,
        model_core::fbank::HOLD_TAU_S,
    ];
    let names = ["dx_um", "dy_um", "dz_um", "e_um"];
    let mut m = fbank_sized(MAX_CHANNELS, &taus, &names[..MAX_OUTPUTS]);
    let Params::Fbank(bank) = &mut m.params else {
        unreachable!()
    };
    assert_eq!(bank.features.len(), MAX_FB_FEATURES);
    for out in bank.outputs.iter_mut() {
        out.intercept = 0.25;
    }
    let span = Span {
        min: -5.0,
        max: 40.0,
    };
    m.bounds = Some(Bounds {
        envelope: hv(&[span; MAX_CHANNELS]),
        half_width: hv(&[1.5; MAX_OUTPUTS]),
        growth: hv(&[2.0; MAX_OUTPUTS]),
    });
    let vm = m.clone().validate().unwrap();
    let bytes = blob_of(&vm);
    assert!(bytes.len() <= MAX_BLOB_LEN, "{} bytes", bytes.len());
    assert_eq!(decode(&bytes).unwrap().model(), &m);
    // It steps; the hold's pole is exactly 1. With every input 3 K up after
    // a first sample of 20 C (first-sample reference: x = 0, then 3), each
    // output moves by 3 x its weights on the raw feature (j % 8 == 0) plus
    // the filters' first step (1 - p) x 3; the holds stay at 0.
    let mut state = ModelState::new();
    let mut y = [0.0; MAX_OUTPUTS];
    vm.step(&mut state, &[20.0; MAX_CHANNELS], &mut y).unwrap();
    assert_eq!(y, [0.25; MAX_OUTPUTS]);
    vm.step(&mut state, &[23.0; MAX_CHANNELS], &mut y).unwrap();
    let poles = vm.fbank_poles();
    assert_eq!(poles[7], 1.0);
    let Params::Fbank(bank) = &m.params else {
        unreachable!()
    };
    for (v, out) in y.iter().zip(&bank.outputs) {
        let expect: f64 = 0.25
            + out
                .coef
                .iter()
                .zip(poles)
                .map(|(w, p)| w * (1.0 - p) * 3.0)
                .sum::<f64>();
        assert!((v - expect).abs() < 1e-12, "{v} vs {expect}");
    }
}

/// Version-1 and version-2 blobs as the old code wrote them: the same body
/// without its last two bytes (the bounds' and the five-point geometry's
/// `None` tags) or without the last one. Both decode, with neither; a body
/// labelled with another version is a byte short or long.
#[test]
fn version_1_and_2_blobs_still_decode() {
    for model in [common::tf_sp2_ambient(), fbank_3x2(false)] {
        let v3 = blob_of(&model.clone().validate().unwrap());
        assert_eq!(v3[v3.len() - 6..v3.len() - 4], [0, 0], "two None tags");
        let body_v1 = &v3[HEADER_LEN..v3.len() - 6];
        let body_v2 = &v3[HEADER_LEN..v3.len() - 5];
        for (version, body) in [(1, body_v1), (2, body_v2)] {
            let old = frame(version, model.kind().code(), body);
            let back = decode(&old).expect("an older version decodes");
            assert_eq!(back.model(), &model, "version {version}");
            assert!(back.bounds().is_none() && back.five_point().is_none());
        }
        for (version, body) in [(2, body_v1), (1, body_v2), (3, body_v2)] {
            assert_eq!(
                decode(&frame(version, model.kind().code(), body)).unwrap_err(),
                model_core::BlobError::Malformed,
                "version {version}"
            );
        }
    }
    // The SP2 + ambient blob's version-1 header, frozen before version 2:
    // 129 body bytes.
    let v3 = blob_of(&common::tf_sp2_ambient().validate().unwrap());
    let v1 = frame(1, 1, &v3[HEADER_LEN..v3.len() - 6]);
    assert_eq!(
        v1[..HEADER_LEN],
        [b'T', b'C', b'M', b'B', 1, 0, 1, 0, 0x81, 0, 0, 0]
    );
}

#[test]
fn each_output_reads_only_the_inputs_of_its_nonzero_coefficients() {
    let vm = fbank_3x2(false).validate().unwrap();
    // dz_um: every feature; dx_um: zero weight on T1 raw and on T2^2.
    assert_eq!(vm.output_inputs(0), 0b111);
    assert_eq!(vm.output_inputs(1), 0b101);
    assert_eq!(vm.position_inputs(), 0);
    assert_eq!(vm.positional_outputs(), 0);
    assert!(ModelKind::Fbank.is_dynamic());
    assert_eq!(ModelKind::from_code(6), Some(ModelKind::Fbank));
    assert_eq!(ModelKind::Fbank.name(), "fbank");
}

/// Envelope of `fbank_3x2(true)`: T1 [-0.5, 12] (width 12.5, relative to
/// its first sample), T2 [0, 8], ambient [-3, 4] (width 7, relative to
/// 20 C); half-widths 1.8 and 0.9 um. Every expected value is a ratio of
/// short decimals, so 1e-12 relative.
#[test]
fn extrapolation_and_band_on_a_small_example() {
    let vm = fbank_3x2(true).validate().unwrap();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
    let mut state = ModelState::new();
    let mut y = [0.0; 2];
    // Before the first step: 0 (T1 and T2 have no reference yet).
    assert_eq!(vm.extrapolation(&state, &[99.0, 99.0, 99.0]), 0.0);
    vm.step(&mut state, &[25.0, 30.0, 20.0], &mut y).unwrap();
    assert_eq!(vm.extrapolation(&state, &[25.0, 30.0, 20.0]), 0.0);
    // T1 13.2 above its first sample: 1.2 beyond 12, over the width 12.5.
    let e = vm.extrapolation(&state, &[38.2, 30.0, 20.0]);
    assert!(close(e, 1.2 / 12.5), "{e}");
    assert!(e < EXTRAPOLATION_FLAG_AT);
    // Ambient 26 C is 6 over 20: 2 beyond 4, over 7. T1 1 below its first
    // sample is 0.5 below -0.5 (0.04): the largest counts.
    let e = vm.extrapolation(&state, &[24.0, 30.0, 26.0]);
    assert!(close(e, 2.0 / 7.0), "{e}");
    assert!(e > ValidModel::EXTRAPOLATION_FLAG_AT);
    assert!(close(
        vm.band_half_width(0, e).unwrap(),
        1.8 * (1.0 + 2.0 / 7.0)
    ));
    assert!(close(vm.band_half_width(1, 0.0).unwrap(), 0.9));
    // Output 1 widens three times as fast (its growth is 3).
    assert!(close(
        vm.band_half_width(1, e).unwrap(),
        0.9 * (1.0 + 3.0 * 2.0 / 7.0)
    ));
    assert_eq!(vm.band_half_width(0, -1.0), Some(1.8));
    assert_eq!(vm.band_half_width(0, f64::NAN), Some(1.8));
    assert_eq!(vm.band_half_width(2, 0.0), None);
    // What step refuses does not count: a wrong count, a NaN, 1e300.
    assert_eq!(vm.extrapolation(&state, &[1e3, 1e3]), 0.0);
    assert!(close(
        vm.extrapolation(&state, &[f64::NAN, 1e300, 26.0]),
        2.0 / 7.0
    ));
    // A span that never moved: width floored at 1e-9 of its size.
    let flat = Span { min: 5.0, max: 5.0 };
    assert!(close(flat.outside(5.5), 0.5 / 5e-9));
    assert_eq!(flat.outside(5.0), 0.0);
    // Without bounds: nothing to say.
    let plain = fbank_3x2(false).validate().unwrap();
    assert_eq!(plain.extrapolation(&state, &[99.0, 99.0, 99.0]), 0.0);
    assert_eq!(plain.band_half_width(0, 0.5), None);
}

/// The largest bank (32 inputs x 4 features) from steady state, after a
/// +1 K step on every input held for 20 of its slowest time constants
/// (4 h at 1 s): every filter has closed all but exp(-20) = 2e-9 of the
/// step, so the output is the sum of the coefficients to 1e-8 of their
/// absolute sum. A refused sample then leaves the memories alone.
#[test]
fn wide_bank_settles_on_its_dc_gain() {
    let vm = fbank_wide(32).validate().unwrap();
    let Params::Fbank(bank) = &vm.model().params else {
        unreachable!()
    };
    let gain: f64 = bank.outputs[0].coef.iter().sum();
    let mut state = ModelState::new();
    let mut y = [0.0];
    vm.step(&mut state, &[20.0; 32], &mut y).unwrap();
    assert_eq!(y[0], 0.0);
    let n = 20 * 14_400; // 20 of the slowest time constant: exp(-20) = 2e-9
    for _ in 0..n {
        vm.step(&mut state, &[21.0; 32], &mut y).unwrap();
    }
    let bound = bank.outputs[0].coef.iter().map(|c| c.abs()).sum::<f64>();
    assert!((y[0] - gain).abs() < 1e-8 * bound, "{} vs {gain}", y[0]);
    let before = state.clone();
    assert!(vm.step(&mut state, &[f64::NAN; 32], &mut y).is_err());
    assert_eq!(state, before);
}

/// A temperature lost for 1200 steps while it rose 5 K along a line,
/// the model stepped with its last good value standing in: bridged on its
/// return, every output is what a model that saw the line computes (to
/// 1e-9 um: the closed form against 1200 roundings), for filters of 10 s
/// to 4 h, the raw and the held feature untouched, a reference of the
/// run's first sample; T2, never lost, is not mended. Without the bridge
/// dz is 17.3 um short.
#[test]
fn a_bridged_memory_is_the_one_the_line_would_have_left() {
    use model_core::fbank::HOLD_TAU_S;
    let fb = bank(
        &[chan("T1", Reference::First), chan("T2", Reference::First)],
        &["dz_um"],
        1.0,
        &[
            feature(0, 1, 0.0),
            feature(0, 1, 10.0),
            feature(0, 1, 3_600.0),
            feature(0, 1, 14_400.0),
            feature(0, 1, HOLD_TAU_S),
            feature(1, 1, 600.0),
        ],
        &[&[1.0, 2.0, 10.0, 4.0, -1.0, 3.0]],
    );
    let n = 1200u32;
    let t1 = |k: u32| 20.0 + 5.0 * f64::from(k) / f64::from(n + 1);
    let t2 = |k: u32| 18.0 + 0.001 * f64::from(k);
    let run = |lost: Option<bool>| {
        let mut state = ModelState::new();
        let mut out = [0.0];
        fb.step(&mut state, &[t1(0), t2(0)], &mut out).unwrap();
        for k in 1..=n {
            let x1 = if lost.is_some() { t1(0) } else { t1(k) };
            fb.step(&mut state, &[x1, t2(k)], &mut out).unwrap();
        }
        if lost == Some(true) {
            fb.bridge(&mut state, 0, (t1(0), t1(n + 1)), n);
        }
        fb.step(&mut state, &[t1(n + 1), t2(n + 1)], &mut out)
            .unwrap();
        out[0]
    };
    let (line, bridged, held) = (run(None), run(Some(true)), run(Some(false)));
    assert!((bridged - line).abs() < 1e-9, "{bridged} vs {line}");
    // The error the bridge removes, weight x 5 K x line_share x p (one
    // step after the return): 10 s 2 x 5 x 0.9912 x 0.9048 = 8.97, 1 h
    // 10 x 5 x 0.1495 x 0.9997 = 7.47, 4 h 4 x 5 x 0.0404 = 0.81 um.
    assert!((line - held - 17.26).abs() < 0.01, "{}", line - held);
    // Nothing to mend before the first step, or with nothing lost.
    let mut fresh = ModelState::new();
    fb.bridge(&mut fresh, 0, (20.0, 25.0), n);
    assert_eq!(fresh, ModelState::new());
    let mut started = ModelState::new();
    fb.step(&mut started, &[t1(0), t2(0)], &mut [0.0]).unwrap();
    let before = started.clone();
    fb.bridge(&mut started, 0, (20.0, 25.0), 0);
    assert_eq!(started, before);
}

/// How long an output takes to forget a wrong stretch of an input: per
/// weighted filter of that input `tau ln(min(lost / tau, 1) / share)`, the
/// longest of them (not the hold of the run's first sample, not a filter
/// with zero weight); a TF entry known by its slowest pole: the worst a
/// pole up to it can need; nothing on a static path.
#[test]
fn settling_is_the_longest_wait_over_the_input_s_weighted_memories() {
    use model_core::fbank::HOLD_TAU_S;
    let (dt_s, share) = (30.0, 0.05);
    let w = |tau: f64, lost: f64| tau * ((lost / tau).min(1.0) / share).ln();
    let fb = bank(
        &[
            chan("T1", Reference::First),
            chan("speed_rpm", Reference::Absolute),
        ],
        &["dx_um", "dz_um"],
        dt_s,
        &[
            feature(0, 1, 0.0),
            feature(0, 1, 900.0),
            feature(0, 1, HOLD_TAU_S),
            feature(1, 2, 600.0),
            feature(1, 1, 14_400.0),
            feature(1, 1, 3_600.0),
        ],
        &[
            &[1.0, 0.5, -1.0, 0.0, 0.0, 0.0],
            &[0.0, 0.0, 0.0, 1e-7, 2e-3, 0.0],
        ],
    );
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
    // 600 s lost: the 4 h filter keeps 4 % (under 5 %), the 10 min one
    // all of it: 600 ln 20. The 1 h filter has no weight on dz.
    assert!(close(fb.settle_s(1, 1, 600.0, share), w(600.0, 600.0)));
    // 2 h lost: now the 4 h filter needs the longer wait.
    let long = w(14_400.0, 7_200.0);
    assert!(long > w(600.0, 7_200.0));
    assert!(close(fb.settle_s(1, 1, 7_200.0, share), long));
    assert!(close(fb.settle_s(0, 0, 900.0, share), w(900.0, 900.0)));
    assert_eq!(fb.settle_s(0, 1, 1e6, share), 0.0, "dx does not read speed");
    assert_eq!(fb.settle_s(1, 0, 1e6, share), 0.0);
    assert_eq!(fb.settle_s(2, 0, 1e6, share), 0.0, "no such output");
    assert_eq!(
        fb.settle_s(1, 1, 20.0, share),
        0.0,
        "under 5 % of every memory"
    );
    // A TF bank: dz from T1 through poles 0.9 and 0.95 (slowest
    // -30 / ln 0.95 = 585 s). Lost 1 h: a pole at 585 s is the worst one
    // up to it. Lost 60 s: the worst pole would be at 60 / (0.05 e) =
    // 441 s, below the slowest, so that one's wait (not the slowest's).
    let tf = Model {
        outputs: outputs(&["dz_um"]),
        params: Params::Tf(hv(&[TfEntry {
            output: 0,
            input: 0,
            a: hv(&[1.0]),
            b: hv(&[1.0, -1.85, 0.855]),
        }])),
        ..fb.model().clone()
    }
    .validate()
    .unwrap();
    // The roots come from an iteration: 1e-6 relative.
    let slow = -dt_s / 0.95f64.ln();
    let near = |a: f64, b: f64| (a - b).abs() < 1e-6 * b;
    assert!(near(tf.settle_s(0, 0, 3_600.0, share), w(slow, 3_600.0)));
    let worst = 60.0 / (share * std::f64::consts::E);
    assert!(near(tf.settle_s(0, 0, 60.0, share), w(worst, 60.0)));
    assert!(tf.settle_s(0, 0, 60.0, share) > w(slow, 60.0));
    assert_eq!(tf.settle_s(0, 1, 3_600.0, share), 0.0);
    // A static model forgets at once.
    let lin = common::linear_seed002().validate().unwrap();
    assert_eq!(lin.settle_s(0, 0, 1e6, share), 0.0);
}
