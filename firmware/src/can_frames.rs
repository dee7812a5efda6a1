//! The hub's CAN 2.0A frames: what the CNC reads on the bus, frozen here and
//! in `firmware/thermcomp.dbc` (spec: `docs/wire-format.md`).
//!
//! CANopen-style COB-ids from the node id (CiA 301 predefined connection set:
//! TPDO1..4 at 0x180/0x280/0x380/0x480 + node, heartbeat at 0x700 + node), so
//! bus analysers label them without configuration. Every signal is
//! little-endian (Intel), byte aligned.
//!
//! | id    | frame        | DLC | sent                                   |
//! |-------|--------------|-----|----------------------------------------|
//! | 0x181 | OFFSETS      | 8   | every sample: outputs 1-3, state, counter |
//! | 0x281 | STATUS       | 8   | every sample: flags, faulty channels, shape, faults |
//! | 0x381 | OFFSETS_EXT  | 8   | every sample when the model has a 4th output |
//! | 0x481 | SLOPE        | 8   | every sample, once per positional model output |
//! | 0x701 | HEARTBEAT    | 1   | every heartbeat period (NMT state; canopen::nmt)   |
//!
//! The frames the hub receives from the CNC (0x201, 0x301) are in
//! `can_rx`.
//!
//! Offsets are signed 16-bit in 0.1 um: thermal offsets are tens of um and
//! the hub clamps them to +-500 um, so +-3276.7 um leaves a 6x margin while
//! 0.1 um is finer than any machine's positioning resolution. Values beyond a
//! signal's range saturate at its end; they never wrap (a wrapped +3300 um
//! would reach the CNC as -3253.6 um).
//!
//! Encoders are generic over [`embedded_can::Frame`] (bxcan's frame on the
//! board, [`RawFrame`] on the host); they return `None` only if the frame
//! type refuses a standard id with at most 8 data bytes, which no conforming
//! type does. The decoders exist for tests and the host replay tool.

use embedded_can::{Frame, Id, StandardId};

use crate::board::CAN_NODE_ID;
use crate::report::{HubState, Report, StatusFlags};

/// OFFSETS frame id: CANopen TPDO1 (0x180 + node id).
pub const OFFSETS_ID: u16 = 0x180 + CAN_NODE_ID;
/// STATUS frame id: CANopen TPDO2 (0x280 + node id).
pub const STATUS_ID: u16 = 0x280 + CAN_NODE_ID;
/// OFFSETS_EXT frame id (4th model output): CANopen TPDO3 (0x380 + node id).
pub const OFFSETS_EXT_ID: u16 = 0x380 + CAN_NODE_ID;
/// SLOPE frame id: CANopen TPDO4 (0x480 + node id).
pub const SLOPE_ID: u16 = 0x480 + CAN_NODE_ID;
/// HEARTBEAT frame id: CANopen NMT error control (0x700 + node id).
pub const HEARTBEAT_ID: u16 = crate::board::CAN_HEARTBEAT_ID;

/// Offset signal scale: um per bit (0.1 um, see the module docs).
pub const OFFSET_UM_PER_BIT: f64 = 0.1;
/// Slope signal scale: um/m per bit (0.001 um/m: over a 2 m axis the
/// rounding is 0.002 um; range +-2147 mm/m, far beyond any thermal slope).
pub const SLOPE_UM_PER_M_PER_BIT: f64 = 0.001;
/// Reference-position scale: mm per bit (1 mm: range +-32.767 m covers any
/// machine axis; 1 mm of reference error at 100 um/m is 0.1 um).
pub const REFERENCE_MM_PER_BIT: f64 = 1.0;
/// Bits of the faulty-channel mask on the bus: inputs 1-24 (the frozen
/// STATUS layout has three bytes for it). A fault on inputs 25-32 still sets
/// [`StatusFlags::SENSOR_FAULT`](crate::report::StatusFlags) and holds the
/// outputs that read it; only its bit is missing on the bus (the serial
/// telemetry carries every channel).
pub const FAULTY_MASK_BITS: u32 = 24;
/// Largest input count STATUS byte 5 carries (5 bits): a 32-input model is
/// reported as 31 (the frozen layout predates 32 inputs).
pub const STATUS_MAX_INPUT_COUNT: usize = 31;
/// Default heartbeat period, ms (CiA 301 object 0x1017 "producer heartbeat
/// time"; 1 s matches the sample period, so a CNC can time out at ~3 s).
pub const DEFAULT_HEARTBEAT_MS: u16 = 1_000;

const _: () = {
    assert!(SLOPE_ID <= 0x7FF && HEARTBEAT_ID == 0x700 + CAN_NODE_ID);
    assert!(FAULTY_MASK_BITS <= 24); // three bytes on the bus
    assert!(crate::offsets::MAX_OUTPUTS <= 4); // OFFSETS + OFFSETS_EXT carry four
    assert!(STATUS_MAX_INPUT_COUNT < 32); // 5 bits of STATUS byte 5
};

/// CANopen NMT state, as the heartbeat's only byte (CiA 301, 7.2.8.3.2.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum NmtState {
    /// Boot-up message (sent once after reset).
    BootUp = 0x00,
    /// Stopped.
    Stopped = 0x04,
    /// Operational: the hub sends its frames.
    Operational = 0x05,
    /// Pre-operational.
    PreOperational = 0x7F,
}

impl NmtState {
    /// The state for a heartbeat byte.
    pub const fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            0x00 => Self::BootUp,
            0x04 => Self::Stopped,
            0x05 => Self::Operational,
            0x7F => Self::PreOperational,
            _ => return None,
        })
    }
}

/// A plain CAN 2.0A data frame for the host (tests, replay tool); prints as
/// candump's `ID#DATA` (e.g. `181#0A00F6FF00000105`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawFrame {
    id: u16,
    data: heapless::Vec<u8, 8>,
}

impl RawFrame {
    /// The 11-bit identifier.
    pub fn raw_id(&self) -> u16 {
        self.id
    }
}

impl Frame for RawFrame {
    /// `None` for extended ids (this bus is CAN 2.0A) or more than 8 bytes.
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        match id.into() {
            Id::Standard(id) => Some(Self {
                id: id.as_raw(),
                data: heapless::Vec::from_slice(data).ok()?,
            }),
            Id::Extended(_) => None,
        }
    }

    /// Always `None`: the hub sends no remote frames.
    fn new_remote(_id: impl Into<Id>, _dlc: usize) -> Option<Self> {
        None
    }

    fn is_extended(&self) -> bool {
        false
    }

    fn is_remote_frame(&self) -> bool {
        false
    }

    fn id(&self) -> Id {
        // `id` came from a `StandardId`, so it is <= 0x7FF.
        StandardId::new(self.id).map_or(Id::Standard(StandardId::ZERO), Id::Standard)
    }

    fn dlc(&self) -> usize {
        self.data.len()
    }

    fn data(&self) -> &[u8] {
        &self.data
    }
}

impl core::fmt::Display for RawFrame {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:03X}#", self.id)?;
        for b in &self.data {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

/// Rounds `value / scale` to the nearest integer (half away from zero) and
/// saturates to `[min, max]`; NaN gives 0. No libm needed.
pub(crate) fn quantise(value: f64, scale: f64, min: i64, max: i64) -> i64 {
    let x = value / scale;
    if x.is_nan() {
        return 0;
    }
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    // `as` saturates at i64's ends; the clamp brings it into the signal's.
    (r as i64).clamp(min, max)
}

fn offset_raw(um: f64) -> [u8; 2] {
    let raw = quantise(
        um,
        OFFSET_UM_PER_BIT,
        i64::from(i16::MIN),
        i64::from(i16::MAX),
    );
    i16::try_from(raw).unwrap_or(0).to_le_bytes()
}

pub(crate) fn frame<F: Frame>(id: u16, data: &[u8]) -> Option<F> {
    F::new(StandardId::new(id)?, data)
}

/// The rolling counter for a report: the low byte of its sample counter, so
/// a CNC that sees it stand still knows the hub has stopped sampling.
pub const fn counter(report: &Report) -> u8 {
    report.seq as u8
}

/// OFFSETS (0x181): outputs 1-3 in 0.1 um, state code, rolling counter.
///
/// Bytes: 0-1 output 1, 2-3 output 2, 4-5 output 3 (i16 LE), 6 state code,
/// 7 counter. Outputs the model lacks are 0.
pub fn encode_offsets<F: Frame>(report: &Report) -> Option<F> {
    let mut d = [0u8; 8];
    for (i, v) in report.offsets.iter().take(3).enumerate() {
        d[2 * i..2 * i + 2].copy_from_slice(&offset_raw(*v));
    }
    d[6] = report.state.code();
    d[7] = counter(report);
    frame(OFFSETS_ID, &d)
}

/// OFFSETS_EXT (0x381): output 4 in 0.1 um (bytes 0-1), bytes 2-5 zero,
/// state code (6) and counter (7) as in OFFSETS so it pairs with it.
pub fn encode_offsets_ext<F: Frame>(report: &Report) -> Option<F> {
    let mut d = [0u8; 8];
    d[0..2].copy_from_slice(&offset_raw(report.offsets.get(3).copied().unwrap_or(0.0)));
    d[6] = report.state.code();
    d[7] = counter(report);
    frame(OFFSETS_EXT_ID, &d)
}

/// What STATUS carries beyond the [`Report`]: the hub's model shape and
/// fault count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StatusInfo {
    /// Inputs of the loaded model (0: no model). `Hub::input_count`.
    pub n_inputs: usize,
    /// Samples refused in a row (`Faults::consecutive`); saturates at 255 on
    /// the bus (at 1 Hz: "more than four minutes").
    pub consecutive_faults: u32,
}

/// STATUS (0x281): whether to trust the offsets.
///
/// Bytes: 0-1 [`StatusFlags`] (u16 LE), 2-4 faulty-channel mask (24 bits,
/// bit i = input i), 5 bits 0-4 input count / bits 5-7 output count,
/// 6 consecutive refused samples (saturating), 7 counter (as OFFSETS).
pub fn encode_status<F: Frame>(report: &Report, info: &StatusInfo) -> Option<F> {
    let mut d = [0u8; 8];
    d[0..2].copy_from_slice(&report.flags.0.to_le_bytes());
    let mask = report.faulty_channels & ((1u32 << FAULTY_MASK_BITS) - 1);
    d[2..5].copy_from_slice(&mask.to_le_bytes()[..3]);
    let inputs = u8::try_from(info.n_inputs.min(STATUS_MAX_INPUT_COUNT)).unwrap_or(31);
    let outputs = report.n_outputs.min(7);
    d[5] = inputs | (outputs << 5);
    d[6] = u8::try_from(info.consecutive_faults).unwrap_or(u8::MAX);
    d[7] = counter(report);
    frame(STATUS_ID, &d)
}

/// SLOPE (0x481), for position-dependent models: the CNC applies
/// offset + slope x (position minus reference), as Siemens TEMP_COMP does
/// (the offset is the output's OFFSETS signal). One frame per positional
/// output, told apart by byte 6.
///
/// Bytes: 0-3 slope (i32 LE, 0.001 um/m), 4-5 reference position (i16 LE,
/// 1 mm), 6 output index (0-based, model output order), 7 counter.
pub fn encode_slope<F: Frame>(
    slope_um_per_m: f64,
    reference_mm: f64,
    output: u8,
    counter: u8,
) -> Option<F> {
    let mut d = [0u8; 8];
    let slope = quantise(
        slope_um_per_m,
        SLOPE_UM_PER_M_PER_BIT,
        i64::from(i32::MIN),
        i64::from(i32::MAX),
    );
    d[0..4].copy_from_slice(&i32::try_from(slope).unwrap_or(0).to_le_bytes());
    let reference = quantise(
        reference_mm,
        REFERENCE_MM_PER_BIT,
        i64::from(i16::MIN),
        i64::from(i16::MAX),
    );
    d[4..6].copy_from_slice(&i16::try_from(reference).unwrap_or(0).to_le_bytes());
    d[6] = output;
    d[7] = counter;
    frame(SLOPE_ID, &d)
}

/// HEARTBEAT (0x701): one byte, the NMT state.
pub fn encode_heartbeat<F: Frame>(state: NmtState) -> Option<F> {
    frame(HEARTBEAT_ID, &[state as u8])
}

/// Most frames of one sample: OFFSETS, STATUS, OFFSETS_EXT and one SLOPE
/// per output.
pub const REPORT_FRAMES_MAX: usize = 3 + crate::offsets::MAX_OUTPUTS;

/// The frames of one sample, in sending order (ascending ids): OFFSETS,
/// STATUS, OFFSETS_EXT when the model has a 4th output, and a SLOPE per
/// positional output (reference position 0 mm, `pipeline`). Empty only if
/// `F` refuses standard frames.
pub fn encode_report<F: Frame>(
    report: &Report,
    info: &StatusInfo,
) -> heapless::Vec<F, REPORT_FRAMES_MAX> {
    let mut out = heapless::Vec::new();
    let ext = if report.n_outputs >= 4 {
        encode_offsets_ext(report)
    } else {
        None
    };
    for f in [encode_offsets(report), encode_status(report, info), ext]
        .into_iter()
        .flatten()
    {
        // Capacity REPORT_FRAMES_MAX holds every frame.
        let _ = out.push(f);
    }
    let n_out = usize::from(report.n_outputs).min(crate::offsets::MAX_OUTPUTS);
    for (j, slope) in report.slopes_um_per_m.iter().enumerate().take(n_out) {
        if report.positional & (1 << j) == 0 {
            continue;
        }
        let output = u8::try_from(j).unwrap_or(u8::MAX);
        if let Some(f) = encode_slope(
            *slope,
            crate::offsets::POSITION_REFERENCE_MM,
            output,
            counter(report),
        ) {
            let _ = out.push(f);
        }
    }
    out
}

/// Why a frame does not decode as one of the hub's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum DecodeError {
    /// Not one of the hub's ids, or for `can_rx::decode_rx` not one the
    /// hub receives (or an extended or remote frame).
    UnknownId,
    /// The data length is not the frame's.
    BadLength {
        /// Expected DLC.
        expected: u8,
        /// DLC found.
        found: u8,
    },
}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::UnknownId => write!(f, "not a thermal-compensation hub frame"),
            Self::BadLength { expected, found } => {
                write!(f, "DLC {found}, expected {expected}")
            }
        }
    }
}

impl core::error::Error for DecodeError {}

/// OFFSETS or OFFSETS_EXT, decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffsetsMsg {
    /// Offsets in um (OFFSETS: outputs 1-3; OFFSETS_EXT: output 4, then 0, 0).
    pub offsets_um: [f64; 3],
    /// State code ([`HubState::from_code`]).
    pub state: u8,
    /// Rolling counter.
    pub counter: u8,
}

/// STATUS, decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatusMsg {
    /// Status flags.
    pub flags: StatusFlags,
    /// Faulty-channel mask (24 bits).
    pub faulty_channels: u32,
    /// Model inputs (0: no model).
    pub n_inputs: u8,
    /// Model outputs.
    pub n_outputs: u8,
    /// Consecutive refused samples (saturated at 255).
    pub consecutive_faults: u8,
    /// Rolling counter.
    pub counter: u8,
}

/// SLOPE, decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlopeMsg {
    /// Slope in um/m.
    pub slope_um_per_m: f64,
    /// Reference position in mm.
    pub reference_mm: f64,
    /// Model output the slope belongs to (0-based).
    pub output: u8,
    /// Rolling counter.
    pub counter: u8,
}

/// Any hub frame, decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Message {
    /// 0x181.
    Offsets(OffsetsMsg),
    /// 0x281.
    Status(StatusMsg),
    /// 0x381.
    OffsetsExt(OffsetsMsg),
    /// 0x481.
    Slope(SlopeMsg),
    /// 0x701: the NMT state byte (see [`NmtState::from_code`]).
    Heartbeat(u8),
}

pub(crate) fn data8<F: Frame>(frame: &F) -> Result<[u8; 8], DecodeError> {
    <[u8; 8]>::try_from(frame.data()).map_err(|_| DecodeError::BadLength {
        expected: 8,
        found: u8::try_from(frame.dlc()).unwrap_or(u8::MAX),
    })
}

fn offset_um(lo: u8, hi: u8) -> f64 {
    f64::from(i16::from_le_bytes([lo, hi])) * OFFSET_UM_PER_BIT
}

/// Decodes any of the hub's frames.
pub fn decode<F: Frame>(frame: &F) -> Result<Message, DecodeError> {
    let id = match frame.id() {
        Id::Standard(id) if !frame.is_remote_frame() => id.as_raw(),
        _ => return Err(DecodeError::UnknownId),
    };
    match id {
        OFFSETS_ID | OFFSETS_EXT_ID => {
            let d = data8(frame)?;
            let msg = OffsetsMsg {
                offsets_um: if id == OFFSETS_ID {
                    [
                        offset_um(d[0], d[1]),
                        offset_um(d[2], d[3]),
                        offset_um(d[4], d[5]),
                    ]
                } else {
                    [offset_um(d[0], d[1]), 0.0, 0.0]
                },
                state: d[6],
                counter: d[7],
            };
            Ok(if id == OFFSETS_ID {
                Message::Offsets(msg)
            } else {
                Message::OffsetsExt(msg)
            })
        }
        STATUS_ID => {
            let d = data8(frame)?;
            Ok(Message::Status(StatusMsg {
                flags: StatusFlags(u16::from_le_bytes([d[0], d[1]])),
                faulty_channels: u32::from_le_bytes([d[2], d[3], d[4], 0]),
                n_inputs: d[5] & 0x1F,
                n_outputs: d[5] >> 5,
                consecutive_faults: d[6],
                counter: d[7],
            }))
        }
        SLOPE_ID => {
            let d = data8(frame)?;
            Ok(Message::Slope(SlopeMsg {
                slope_um_per_m: f64::from(i32::from_le_bytes([d[0], d[1], d[2], d[3]]))
                    * SLOPE_UM_PER_M_PER_BIT,
                reference_mm: f64::from(i16::from_le_bytes([d[4], d[5]])) * REFERENCE_MM_PER_BIT,
                output: d[6],
                counter: d[7],
            }))
        }
        HEARTBEAT_ID => match frame.data() {
            [state] => Ok(Message::Heartbeat(*state)),
            other => Err(DecodeError::BadLength {
                expected: 1,
                found: u8::try_from(other.len()).unwrap_or(u8::MAX),
            }),
        },
        _ => Err(DecodeError::UnknownId),
    }
}

/// The decoded state of an OFFSETS frame, if the code is known.
pub fn state_of(msg: &OffsetsMsg) -> Option<HubState> {
    HubState::from_code(msg.state)
}

#[cfg(test)]
mod tests;
