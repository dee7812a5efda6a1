//! Exact bytes, round trips, saturation, and the shared vectors that
//! `scripts/check_dbc.py` checks against the DBC with cantools.

use super::*;
use crate::offsets::MAX_OUTPUTS;

fn report(seq: u32, offsets: [f64; MAX_OUTPUTS], n_outputs: u8, state: HubState) -> Report {
    Report {
        seq,
        offsets,
        n_outputs,
        state,
        flags: StatusFlags::default(),
        faulty_channels: 0,
        ..Report::default()
    }
}

fn hex(f: &RawFrame) -> std::string::String {
    f.data().iter().map(|b| format!("{b:02X}")).collect()
}

#[test]
fn offsets_exact_bytes() {
    let r = report(0x0105, [1.0, -1.0, 12.34, 0.0], 3, HubState::Running);
    let f: RawFrame = encode_offsets(&r).unwrap();
    assert_eq!(f.raw_id(), 0x181);
    assert_eq!(f.data(), &[0x0A, 0x00, 0xF6, 0xFF, 0x7B, 0x00, 0x01, 0x05]);
    assert_eq!(f.to_string(), "181#0A00F6FF7B000105");
}

#[test]
fn offsets_round_trip_within_half_a_bit() {
    for v in [-500.0, -123.456, -0.04, 0.0, 0.05, 0.149, 7.77, 499.99] {
        let r = report(9, [v, -v, v / 2.0, 0.0], 3, HubState::Holding);
        let f: RawFrame = encode_offsets(&r).unwrap();
        let Ok(Message::Offsets(m)) = decode(&f) else {
            panic!("{f}")
        };
        for (got, want) in m.offsets_um.iter().zip([v, -v, v / 2.0]) {
            assert!((got - want).abs() <= 0.05 + 1e-12, "{got} vs {want}");
        }
        assert_eq!(state_of(&m), Some(HubState::Holding));
        assert_eq!(m.counter, 9);
    }
}

#[test]
fn offsets_saturate_never_wrap() {
    let r = report(
        0,
        [3300.0, -1e300, f64::INFINITY, 0.0],
        3,
        HubState::Running,
    );
    let f: RawFrame = encode_offsets(&r).unwrap();
    assert_eq!(&f.data()[..6], &[0xFF, 0x7F, 0x00, 0x80, 0xFF, 0x7F]);
    let nan = report(0, [f64::NAN, 0.0, 0.0, 0.0], 1, HubState::Running);
    let f: RawFrame = encode_offsets(&nan).unwrap();
    assert_eq!(&f.data()[..2], &[0, 0]);
}

#[test]
fn counter_rolls_with_the_sample() {
    let f: RawFrame = encode_offsets(&report(0x1FF, [0.0; 4], 1, HubState::Running)).unwrap();
    assert_eq!(f.data()[7], 0xFF);
    let f: RawFrame = encode_offsets(&report(0x200, [0.0; 4], 1, HubState::Running)).unwrap();
    assert_eq!(f.data()[7], 0x00);
}

#[test]
fn status_exact_bytes_and_round_trip() {
    let mut r = report(0x42, [0.0; 4], 4, HubState::Holding);
    r.flags = StatusFlags(StatusFlags::SENSOR_FAULT | StatusFlags::STALE);
    // Bits above the 24 the bus carries (inputs 25-32 of a 32-input
    // model) are dropped; SENSOR_FAULT still says a channel failed.
    r.faulty_channels = 0xFF80_0005;
    let info = StatusInfo {
        n_inputs: 24,
        consecutive_faults: 300,
    };
    let f: RawFrame = encode_status(&r, &info).unwrap();
    assert_eq!(f.raw_id(), 0x281);
    assert_eq!(f.data(), &[0x05, 0x00, 0x05, 0x00, 0x80, 0x98, 0xFF, 0x42]);
    assert_eq!(
        decode(&f),
        Ok(Message::Status(StatusMsg {
            flags: r.flags,
            faulty_channels: 0x80_0005,
            n_inputs: 24,
            n_outputs: 4,
            consecutive_faults: 255,
            counter: 0x42,
        }))
    );
}

/// A 32-input model: the frozen 5-bit count saturates at 31, and a fault
/// on input 31 alone leaves the 24-bit mask empty but the flag set.
#[test]
fn status_of_a_32_input_model() {
    let mut r = report(7, [0.0; 4], 1, HubState::Holding);
    r.flags = StatusFlags(StatusFlags::SENSOR_FAULT);
    r.faulty_channels = 1 << 31;
    let info = StatusInfo {
        n_inputs: 32,
        consecutive_faults: 1,
    };
    let f: RawFrame = encode_status(&r, &info).unwrap();
    assert_eq!(
        f.data(),
        &[0x01, 0x00, 0x00, 0x00, 0x00, 31 | (1 << 5), 1, 7]
    );
}

#[test]
fn fourth_output_goes_in_offsets_ext() {
    let r = report(3, [1.0, 2.0, 3.0, -250.0], 4, HubState::Running);
    let frames: heapless::Vec<RawFrame, REPORT_FRAMES_MAX> =
        encode_report(&r, &StatusInfo::default());
    let ids: std::vec::Vec<u16> = frames.iter().map(RawFrame::raw_id).collect();
    assert_eq!(ids, [0x181, 0x281, 0x381]);
    assert_eq!(frames[2].data(), &[0x3C, 0xF6, 0, 0, 0, 0, 0x01, 0x03]);
    let three = report(3, [1.0, 2.0, 3.0, 0.0], 3, HubState::Running);
    let frames: heapless::Vec<RawFrame, REPORT_FRAMES_MAX> =
        encode_report(&three, &StatusInfo::default());
    assert_eq!(frames.len(), 2);
}

/// One SLOPE frame per positional output, after the others (ascending
/// ids), each naming its output, reference 0 mm, and the report's counter.
#[test]
fn positional_outputs_get_slope_frames() {
    let mut r = report(9, [0.0, 2.0, 0.0, 0.0], 3, HubState::Running);
    r.positional = 0b101;
    r.slopes_um_per_m = [12.345, 99.0, -3.0, 0.0];
    let frames: heapless::Vec<RawFrame, REPORT_FRAMES_MAX> =
        encode_report(&r, &StatusInfo::default());
    let ids: std::vec::Vec<u16> = frames.iter().map(RawFrame::raw_id).collect();
    assert_eq!(ids, [0x181, 0x281, 0x481, 0x481]);
    let slopes: std::vec::Vec<(u8, f64, f64)> = frames[2..]
        .iter()
        .map(|f| match decode(f) {
            Ok(Message::Slope(m)) => {
                assert_eq!(m.counter, 9);
                (m.output, m.slope_um_per_m, m.reference_mm)
            }
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(slopes.len(), 2);
    // 0.001 um/m resolution: round to nearest.
    assert_eq!(slopes[0].0, 0);
    assert!((slopes[0].1 - 12.345).abs() < 0.0005 + 1e-12);
    assert_eq!((slopes[1].0, slopes[1].1, slopes[1].2), (2, -3.0, 0.0));
    // Every output positional with a 4th output: 3 + 4 frames, all fit.
    let mut all = report(1, [0.0; 4], 4, HubState::Running);
    all.positional = 0b1111;
    let frames: heapless::Vec<RawFrame, REPORT_FRAMES_MAX> =
        encode_report(&all, &StatusInfo::default());
    assert_eq!(frames.len(), REPORT_FRAMES_MAX);
}

#[test]
fn slope_exact_bytes_saturation_and_round_trip() {
    let f: RawFrame = encode_slope(11.5, 250.0, 2, 7).unwrap();
    assert_eq!(f.raw_id(), 0x481);
    // 11500 = 0x2CEC, 250 = 0xFA.
    assert_eq!(f.data(), &[0xEC, 0x2C, 0, 0, 0xFA, 0, 2, 7]);
    let Ok(Message::Slope(m)) = decode(&f) else {
        panic!()
    };
    assert_eq!(
        (m.slope_um_per_m, m.reference_mm, m.output),
        (11.5, 250.0, 2)
    );
    let f: RawFrame = encode_slope(1e12, -1e9, 0, 0).unwrap();
    assert_eq!(f.data(), &[0xFF, 0xFF, 0xFF, 0x7F, 0x00, 0x80, 0, 0]);
}

#[test]
fn heartbeat_bytes_and_period() {
    let f: RawFrame = encode_heartbeat(NmtState::Operational).unwrap();
    assert_eq!(f.to_string(), "701#05");
    assert_eq!(decode(&f), Ok(Message::Heartbeat(0x05)));
    assert_eq!(NmtState::from_code(0x05), Some(NmtState::Operational));
}

#[test]
fn decoder_refuses_foreign_frames() {
    let f = RawFrame::new(StandardId::new(0x182).unwrap(), &[0; 8]).unwrap();
    assert_eq!(decode(&f), Err(DecodeError::UnknownId));
    let f = RawFrame::new(StandardId::new(0x181).unwrap(), &[0; 7]).unwrap();
    assert_eq!(
        decode(&f),
        Err(DecodeError::BadLength {
            expected: 8,
            found: 7
        })
    );
    let ext = embedded_can::ExtendedId::new(0x181).unwrap();
    assert!(RawFrame::new(ext, &[]).is_none());
    assert!(RawFrame::new(StandardId::ZERO, &[0; 9]).is_none());
}

// ---- Shared vectors: the Rust encoder and the DBC (through cantools) agree.

/// One vector: frame bytes and the physical signal values the DBC must give.
fn vector(name: &str, f: &RawFrame, signals: &[(&str, f64)]) -> std::string::String {
    let sigs: std::vec::Vec<std::string::String> = signals
        .iter()
        .map(|(n, v)| format!("\"{n}\": {v}"))
        .collect();
    format!(
        "    {{\"name\": \"{name}\", \"id\": {}, \"data\": \"{}\", \"signals\": {{{}}}}}",
        f.raw_id(),
        hex(f),
        sigs.join(", ")
    )
}

fn flag_signals(flags: StatusFlags) -> std::vec::Vec<(&'static str, f64)> {
    const NAMES: [&str; 13] = [
        "SensorFault",
        "SpikeRejected",
        "Stale",
        "ModelFault",
        "Clamped",
        "SlewLimited",
        "NoModel",
        "Uploading",
        "Recovering",
        "Extrapolating",
        "Implausible",
        "RateOfChange",
        "Stuck",
    ];
    NAMES
        .iter()
        .enumerate()
        .map(|(i, n)| (*n, f64::from(flags.0 >> i & 1)))
        .collect()
}

/// Builds the vectors from known values, checking each against this
/// module's decoder on the way.
fn vectors() -> std::string::String {
    let mut out = std::vec::Vec::new();
    let offsets = |name: &str, r: &Report, out: &mut std::vec::Vec<_>| {
        let f: RawFrame = encode_offsets(r).unwrap();
        let Ok(Message::Offsets(m)) = decode(&f) else {
            panic!()
        };
        out.push(vector(
            name,
            &f,
            &[
                ("OffsetOut1", m.offsets_um[0]),
                ("OffsetOut2", m.offsets_um[1]),
                ("OffsetOut3", m.offsets_um[2]),
                ("HubState", f64::from(m.state)),
                ("Counter", f64::from(m.counter)),
            ],
        ));
    };
    let status = |name: &str, r: &Report, info: &StatusInfo, out: &mut std::vec::Vec<_>| {
        let f: RawFrame = encode_status(r, info).unwrap();
        let Ok(Message::Status(m)) = decode(&f) else {
            panic!()
        };
        let mut s = flag_signals(m.flags);
        s.extend([
            ("FaultyChannels", f64::from(m.faulty_channels)),
            ("InputCount", f64::from(m.n_inputs)),
            ("OutputCount", f64::from(m.n_outputs)),
            ("ConsecutiveFaults", f64::from(m.consecutive_faults)),
            ("Counter", f64::from(m.counter)),
        ]);
        out.push(vector(name, &f, &s));
    };

    let mut nominal = report(0x0105, [1.0, -1.0, 12.34, 0.0], 3, HubState::Running);
    nominal.flags = StatusFlags(StatusFlags::SLEW_LIMITED);
    let info = StatusInfo {
        n_inputs: 5,
        consecutive_faults: 0,
    };
    offsets("offsets_nominal", &nominal, &mut out);
    status("status_nominal", &nominal, &info, &mut out);

    let mut fault = report(
        0x42,
        [5000.0, -5000.0, -123.45, -250.0],
        4,
        HubState::Holding,
    );
    fault.flags = StatusFlags(
        StatusFlags::SENSOR_FAULT
            | StatusFlags::STALE
            | StatusFlags::CLAMPED
            | StatusFlags::RECOVERING
            | StatusFlags::EXTRAPOLATING,
    );
    fault.faulty_channels = 0x80_0005;
    let info = StatusInfo {
        n_inputs: 24,
        consecutive_faults: 300,
    };
    offsets("offsets_saturated", &fault, &mut out);
    status("status_fault", &fault, &info, &mut out);
    let f: RawFrame = encode_offsets_ext(&fault).unwrap();
    let Ok(Message::OffsetsExt(m)) = decode(&f) else {
        panic!()
    };
    out.push(vector(
        "offsets_ext",
        &f,
        &[
            ("OffsetOut4", m.offsets_um[0]),
            ("HubState", f64::from(m.state)),
            ("Counter", f64::from(m.counter)),
        ],
    ));

    let mut none = report(0xFFFF_FFFF, [0.0; 4], 0, HubState::NoModel);
    none.flags = StatusFlags(StatusFlags::NO_MODEL | StatusFlags::UPLOADING);
    offsets("offsets_no_model", &none, &mut out);
    status("status_no_model", &none, &StatusInfo::default(), &mut out);

    // The plausibility faults (bits 10-12), T1 and T3 faulty, Holding.
    let mut implausible = report(0x77, [3.0, 0.0, 0.0, 0.0], 1, HubState::Holding);
    implausible.flags =
        StatusFlags(StatusFlags::IMPLAUSIBLE | StatusFlags::RATE_OF_CHANGE | StatusFlags::STUCK);
    implausible.faulty_channels = 0b101;
    let info = StatusInfo {
        n_inputs: 3,
        consecutive_faults: 12,
    };
    status("status_implausible", &implausible, &info, &mut out);

    for (name, slope, reference, output, counter) in [
        ("slope_nominal", 11.5, 250.0, 2, 7),
        ("slope_negative", -42.125, -1200.0, 0, 255),
        ("slope_saturated", 1e12, -1e9, 1, 0),
    ] {
        let f: RawFrame = encode_slope(slope, reference, output, counter).unwrap();
        let Ok(Message::Slope(m)) = decode(&f) else {
            panic!()
        };
        out.push(vector(
            name,
            &f,
            &[
                ("Slope", m.slope_um_per_m),
                ("ReferencePos", m.reference_mm),
                ("SlopeOutput", f64::from(m.output)),
                ("Counter", f64::from(m.counter)),
            ],
        ));
    }
    let f: RawFrame = encode_heartbeat(NmtState::Operational).unwrap();
    out.push(vector("heartbeat_operational", &f, &[("NmtState", 5.0)]));

    // Frames the hub receives (`can_rx`); "not available" is the raw
    // 0x7FFF.. value, which the DBC decodes as its scaled number.
    use crate::can_rx::{
        decode_rx, encode_spindle, encode_tool_position, RxMessage, Spindle, ToolPosition,
        NOT_AVAILABLE_I16, NOT_AVAILABLE_I32, POSITION_MM_PER_BIT, POWER_KW_PER_BIT,
        SPEED_RPM_PER_BIT, TOOL_MM_PER_BIT,
    };
    let na32 = |scale: f64| f64::from(NOT_AVAILABLE_I32) * scale;
    for (name, speed, power) in [
        ("cnc_spindle_nominal", Some(12_000.0), Some(15.5)),
        ("cnc_spindle_reverse_braking", Some(-800.25), Some(-2.5)),
        ("cnc_spindle_not_available", None, None),
        ("cnc_spindle_saturated", Some(1e12), Some(-1e9)),
    ] {
        let f: RawFrame = encode_spindle(&Spindle {
            speed_rpm: speed,
            power_kw: power,
        })
        .unwrap();
        let Ok(RxMessage::Spindle(m)) = decode_rx(&f) else {
            panic!()
        };
        out.push(vector(
            name,
            &f,
            &[
                (
                    "SpindleSpeed",
                    m.speed_rpm.unwrap_or(na32(SPEED_RPM_PER_BIT)),
                ),
                (
                    "SpindlePower",
                    m.power_kw
                        .unwrap_or(f64::from(NOT_AVAILABLE_I16) * POWER_KW_PER_BIT),
                ),
            ],
        ));
    }
    for (name, tool, position) in [
        ("cnc_tool_position_nominal", Some(123.456), Some(-0.5)),
        ("cnc_tool_only", Some(250.0), None),
        ("cnc_position_only", None, Some(600.0)),
    ] {
        let f: RawFrame = encode_tool_position(&ToolPosition {
            tool_mm: tool,
            position_mm: position,
        })
        .unwrap();
        let Ok(RxMessage::ToolPosition(m)) = decode_rx(&f) else {
            panic!()
        };
        out.push(vector(
            name,
            &f,
            &[
                ("ToolLength", m.tool_mm.unwrap_or(na32(TOOL_MM_PER_BIT))),
                (
                    "AxisPosition",
                    m.position_mm.unwrap_or(na32(POSITION_MM_PER_BIT)),
                ),
            ],
        ));
    }
    // CANopen (`canopen::Node`): boot-up, an NMT command it obeys, an EMCY,
    // an SDO request and the node's response.
    use crate::canopen::{Node, Settings};
    use embedded_can::StandardId;
    let mut node = Node::new(Settings::DEFAULT).unwrap();
    let f: RawFrame = node.boot(0).unwrap();
    out.push(vector("canopen_boot_up", &f, &[("NmtState", 0.0)]));
    let nmt = RawFrame::new(StandardId::new(0x000).unwrap(), &[0x01, 0x01]).unwrap();
    assert!(node.on_frame(&nmt, 0).frames.is_empty());
    out.push(vector(
        "canopen_nmt_start_node_1",
        &nmt,
        &[("NmtCommand", 1.0), ("NmtNodeId", 1.0)],
    ));
    let mut faulty = report(9, [0.0; 4], 1, HubState::Holding);
    faulty.flags = StatusFlags(StatusFlags::SENSOR_FAULT);
    faulty.faulty_channels = 0x80_0004;
    let frames: heapless::Vec<RawFrame, { crate::canopen::node::SAMPLE_FRAMES_MAX }> =
        node.on_sample(&faulty, &StatusInfo::default());
    out.push(vector(
        "canopen_emcy_sensor_fault",
        &frames[0],
        &[
            ("ErrorCode", 20480.0),
            ("ErrorRegister", 129.0),
            ("EmcyStatusFlags", 1.0),
            ("EmcyFaultyChannels", f64::from(0x80_0004)),
        ],
    ));
    let req = RawFrame::new(
        StandardId::new(0x601).unwrap(),
        &[0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0],
    )
    .unwrap();
    let resp = node.on_frame(&req, 0).frames[0].clone();
    let sdo = |d: &[u8]| {
        [
            ("Command", f64::from(d[0])),
            ("Index", f64::from(u16::from_le_bytes([d[1], d[2]]))),
            ("SubIndex", f64::from(d[3])),
            (
                "Data",
                f64::from(u32::from_le_bytes([d[4], d[5], d[6], d[7]])),
            ),
        ]
    };
    out.push(vector("canopen_sdo_upload_request", &req, &sdo(req.data())));
    out.push(vector(
        "canopen_sdo_upload_response",
        &resp,
        &sdo(resp.data()),
    ));
    format!("{{\n  \"vectors\": [\n{}\n  ]\n}}\n", out.join(",\n"))
}

/// The committed `firmware/tests/data/can_vectors.json` is exactly what this
/// encoder produces; `scripts/check_dbc.py` (no arguments) decodes the same
/// bytes with cantools and the DBC and checks the signal values, so the DBC
/// and the encoder are tied together. `UPDATE_CAN_VECTORS=1` rewrites it.
#[test]
fn shared_vectors_match_the_encoder() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/can_vectors.json");
    let want = vectors();
    if std::env::var_os("UPDATE_CAN_VECTORS").is_some() {
        std::fs::write(path, &want).unwrap();
    }
    let have = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        have == want,
        "{path} differs from the encoder's output; if the change is intended, \
         rerun with UPDATE_CAN_VECTORS=1 and then scripts/check_dbc.py"
    );
}
