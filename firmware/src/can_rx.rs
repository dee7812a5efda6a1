//! The CAN frames the hub receives: the model inputs only the CNC knows
//! (CONTRACT section 5), frozen here and in `firmware/thermcomp.dbc`
//! (spec: `docs/wire-format.md`, "Frames from the CNC").
//!
//! Ids are those of CANopen RPDO1/RPDO2 of the hub's node (CiA 301
//! predefined connection set, 0x200/0x300 + node id), so a later CANopen
//! object dictionary can take them over as RPDOs without changing the wire.
//!
//! | id    | frame         | DLC | sent by the CNC                      |
//! |-------|---------------|-----|--------------------------------------|
//! | 0x201 | SPINDLE       | 8   | periodically (e.g. every 100-1000 ms): speed, power |
//! | 0x301 | TOOL_POSITION | 8   | on every tool change, and periodically if it carries a position |
//!
//! Every signal is little-endian, two's complement, byte aligned. The
//! signal's largest raw value (`0x7FFF`, `0x7FFF_FFFF`) is **not
//! available**: the frame carries no value for it (the CNC does not supply
//! it, or not in this frame), and the value last received keeps its age
//! (`cnc_inputs`). The encoder saturates other values one below it, so a
//! huge value never reads as "not available", and never wraps.
//!
//! The encoders exist for the host (tests, `thermcomp replay` playing the
//! CNC); the board only decodes ([`decode_rx`]).

use embedded_can::{Frame, Id};

use crate::board::CAN_NODE_ID;
use crate::can_frames::{data8, frame, quantise, DecodeError};

/// SPINDLE frame id: CANopen RPDO1 (0x200 + node id).
pub const SPINDLE_ID: u16 = 0x200 + CAN_NODE_ID;
/// TOOL_POSITION frame id: CANopen RPDO2 (0x300 + node id).
pub const TOOL_POSITION_ID: u16 = 0x300 + CAN_NODE_ID;

/// Spindle speed scale, rpm per bit, in an i32: +-21,474,836.46 rpm, far
/// beyond any spindle (motor spindles reach ~60,000 rpm, which an i16 at
/// 1 rpm would not hold); 0.01 rpm is finer than any drive reports.
/// Negative: counter-clockwise (M04).
pub const SPEED_RPM_PER_BIT: f64 = 0.01;
/// Spindle power scale, kW per bit, in an i16: +-327.66 kW covers the
/// largest machining-centre spindles (~100 kW); negative while braking
/// (regenerative). 0.01 kW = 10 W, below a spindle's idle losses.
pub const POWER_KW_PER_BIT: f64 = 0.01;
/// Tool length scale, mm per bit, in an i32: 0.001 mm is a tool presetter's
/// resolution; the range (+-2,147,483.646 mm) is far wider than the
/// pipeline accepts (`pipeline::MAX_TOOL_LENGTH_MM`, 0..=1000 mm).
pub const TOOL_MM_PER_BIT: f64 = 0.001;
/// Axis position scale, mm per bit, in an i32: 0.001 mm (1 um, a CNC's
/// display resolution), range +-2,147,483.646 mm covers any machine axis.
pub const POSITION_MM_PER_BIT: f64 = 0.001;

/// "Not available" in an i32 signal.
pub const NOT_AVAILABLE_I32: i32 = i32::MAX;
/// "Not available" in an i16 signal.
pub const NOT_AVAILABLE_I16: i16 = i16::MAX;

const _: () = assert!(SPINDLE_ID <= 0x7FF && TOOL_POSITION_ID <= 0x7FF);

/// SPINDLE (0x201): bytes 0-3 speed (i32, 0.01 rpm), 4-5 power (i16,
/// 0.01 kW), 6-7 reserved (0, ignored on receipt).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spindle {
    /// Spindle speed, rpm (`None`: not available).
    pub speed_rpm: Option<f64>,
    /// Spindle power, kW (`None`: not available).
    pub power_kw: Option<f64>,
}

/// TOOL_POSITION (0x301): bytes 0-3 tool length (i32, 0.001 mm), 4-7 axis
/// position (i32, 0.001 mm).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToolPosition {
    /// Length of the tool now in the spindle, mm (`None`: not in this frame).
    pub tool_mm: Option<f64>,
    /// The axis position a positional model reads, mm (`None`: not available).
    pub position_mm: Option<f64>,
}

/// A frame from the CNC, decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RxMessage {
    /// 0x201.
    Spindle(Spindle),
    /// 0x301.
    ToolPosition(ToolPosition),
}

fn raw_i32(value: Option<f64>, scale: f64) -> [u8; 4] {
    let raw = match value {
        Some(v) if !v.is_nan() => {
            let q = quantise(
                v,
                scale,
                i64::from(i32::MIN),
                i64::from(NOT_AVAILABLE_I32) - 1,
            );
            i32::try_from(q).unwrap_or(NOT_AVAILABLE_I32)
        }
        _ => NOT_AVAILABLE_I32,
    };
    raw.to_le_bytes()
}

fn raw_i16(value: Option<f64>, scale: f64) -> [u8; 2] {
    let raw = match value {
        Some(v) if !v.is_nan() => {
            let q = quantise(
                v,
                scale,
                i64::from(i16::MIN),
                i64::from(NOT_AVAILABLE_I16) - 1,
            );
            i16::try_from(q).unwrap_or(NOT_AVAILABLE_I16)
        }
        _ => NOT_AVAILABLE_I16,
    };
    raw.to_le_bytes()
}

fn value_i32(b: [u8; 4], scale: f64) -> Option<f64> {
    let raw = i32::from_le_bytes(b);
    (raw != NOT_AVAILABLE_I32).then(|| f64::from(raw) * scale)
}

fn value_i16(b: [u8; 2], scale: f64) -> Option<f64> {
    let raw = i16::from_le_bytes(b);
    (raw != NOT_AVAILABLE_I16).then(|| f64::from(raw) * scale)
}

/// SPINDLE (0x201). `None` or NaN is sent as "not available"; other values
/// round to the nearest step and saturate within the signal's range.
pub fn encode_spindle<F: Frame>(msg: &Spindle) -> Option<F> {
    let mut d = [0u8; 8];
    d[0..4].copy_from_slice(&raw_i32(msg.speed_rpm, SPEED_RPM_PER_BIT));
    d[4..6].copy_from_slice(&raw_i16(msg.power_kw, POWER_KW_PER_BIT));
    frame(SPINDLE_ID, &d)
}

/// TOOL_POSITION (0x301), as [`encode_spindle`].
pub fn encode_tool_position<F: Frame>(msg: &ToolPosition) -> Option<F> {
    let mut d = [0u8; 8];
    d[0..4].copy_from_slice(&raw_i32(msg.tool_mm, TOOL_MM_PER_BIT));
    d[4..8].copy_from_slice(&raw_i32(msg.position_mm, POSITION_MM_PER_BIT));
    frame(TOOL_POSITION_ID, &d)
}

/// Decodes a frame from the CNC: [`DecodeError::UnknownId`] for any other
/// id (and extended or remote frames), [`DecodeError::BadLength`] unless
/// DLC 8.
pub fn decode_rx<F: Frame>(frame: &F) -> Result<RxMessage, DecodeError> {
    let id = match frame.id() {
        Id::Standard(id) if !frame.is_remote_frame() => id.as_raw(),
        _ => return Err(DecodeError::UnknownId),
    };
    match id {
        SPINDLE_ID => {
            let d = data8(frame)?;
            Ok(RxMessage::Spindle(Spindle {
                speed_rpm: value_i32([d[0], d[1], d[2], d[3]], SPEED_RPM_PER_BIT),
                power_kw: value_i16([d[4], d[5]], POWER_KW_PER_BIT),
            }))
        }
        TOOL_POSITION_ID => {
            let d = data8(frame)?;
            Ok(RxMessage::ToolPosition(ToolPosition {
                tool_mm: value_i32([d[0], d[1], d[2], d[3]], TOOL_MM_PER_BIT),
                position_mm: value_i32([d[4], d[5], d[6], d[7]], POSITION_MM_PER_BIT),
            }))
        }
        _ => Err(DecodeError::UnknownId),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::can_frames::RawFrame;
    use embedded_can::StandardId;

    fn hex(f: &RawFrame) -> std::string::String {
        f.to_string()
    }

    #[test]
    fn spindle_exact_bytes() {
        // 12000 rpm = 1,200,000 = 0x00124F80; 15.5 kW = 1550 = 0x060E.
        let f: RawFrame = encode_spindle(&Spindle {
            speed_rpm: Some(12_000.0),
            power_kw: Some(15.5),
        })
        .unwrap();
        assert_eq!(f.raw_id(), 0x201);
        assert_eq!(hex(&f), "201#804F12000E060000");
        // M04 at 800.25 rpm: -80025 = 0xFFFEC767; braking -2.5 kW = -250 = 0xFF06.
        let f: RawFrame = encode_spindle(&Spindle {
            speed_rpm: Some(-800.25),
            power_kw: Some(-2.5),
        })
        .unwrap();
        assert_eq!(hex(&f), "201#67C7FEFF06FF0000");
    }

    #[test]
    fn not_available_and_saturation() {
        let f: RawFrame = encode_spindle(&Spindle {
            speed_rpm: None,
            power_kw: Some(f64::NAN),
        })
        .unwrap();
        assert_eq!(hex(&f), "201#FFFFFF7FFF7F0000");
        assert_eq!(
            decode_rx(&f),
            Ok(RxMessage::Spindle(Spindle {
                speed_rpm: None,
                power_kw: None
            }))
        );
        // Too big saturates one below "not available", never wraps.
        let f: RawFrame = encode_spindle(&Spindle {
            speed_rpm: Some(1e12),
            power_kw: Some(f64::NEG_INFINITY),
        })
        .unwrap();
        assert_eq!(hex(&f), "201#FEFFFF7F00800000");
        let Ok(RxMessage::Spindle(m)) = decode_rx(&f) else {
            panic!()
        };
        assert_eq!(m.speed_rpm, Some(f64::from(i32::MAX - 1) * 0.01));
        assert_eq!(m.power_kw, Some(-327.68));
    }

    #[test]
    fn tool_position_exact_bytes_and_round_trip() {
        // 123.456 mm = 123456 = 0x0001E240; -0.5 mm = -500 = 0xFFFFFE0C.
        let msg = ToolPosition {
            tool_mm: Some(123.456),
            position_mm: Some(-0.5),
        };
        let f: RawFrame = encode_tool_position(&msg).unwrap();
        assert_eq!(hex(&f), "301#40E201000CFEFFFF");
        let Ok(RxMessage::ToolPosition(m)) = decode_rx(&f) else {
            panic!()
        };
        assert!((m.tool_mm.unwrap() - 123.456).abs() < 1e-9);
        assert_eq!(m.position_mm, Some(-0.5));
        let f: RawFrame = encode_tool_position(&ToolPosition {
            tool_mm: None,
            position_mm: Some(600.0),
        })
        .unwrap();
        assert_eq!(hex(&f), "301#FFFFFF7FC0270900");
    }

    #[test]
    fn round_trips_within_half_a_step() {
        for v in [-59_999.994, -1.0, 0.0, 0.004, 0.006, 12_345.678, 60_000.0] {
            let f: RawFrame = encode_spindle(&Spindle {
                speed_rpm: Some(v),
                power_kw: Some(v / 1000.0),
            })
            .unwrap();
            let Ok(RxMessage::Spindle(m)) = decode_rx(&f) else {
                panic!()
            };
            assert!((m.speed_rpm.unwrap() - v).abs() <= 0.005 + 1e-9, "{v}");
            assert!((m.power_kw.unwrap() - v / 1000.0).abs() <= 0.005 + 1e-9);
            let f: RawFrame = encode_tool_position(&ToolPosition {
                tool_mm: Some(v / 100.0),
                position_mm: Some(v),
            })
            .unwrap();
            let Ok(RxMessage::ToolPosition(m)) = decode_rx(&f) else {
                panic!()
            };
            assert!((m.tool_mm.unwrap() - v / 100.0).abs() <= 0.0005 + 1e-9);
            assert!((m.position_mm.unwrap() - v).abs() <= 0.0005 + 1e-9);
        }
    }

    #[test]
    fn other_frames_are_refused() {
        let f = RawFrame::new(StandardId::new(0x181).unwrap(), &[0; 8]).unwrap();
        assert_eq!(decode_rx(&f), Err(DecodeError::UnknownId));
        let f = RawFrame::new(StandardId::new(0x202).unwrap(), &[0; 8]).unwrap();
        assert_eq!(decode_rx(&f), Err(DecodeError::UnknownId));
        let f = RawFrame::new(StandardId::new(0x201).unwrap(), &[0; 6]).unwrap();
        assert_eq!(
            decode_rx(&f),
            Err(DecodeError::BadLength {
                expected: 8,
                found: 6
            })
        );
    }
}
