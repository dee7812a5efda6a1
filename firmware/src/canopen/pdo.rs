//! Process data objects (CiA 301 §7.2.2): the TPDOs built from the
//! mapped objects, the RPDOs split into them.
//!
//! Default mapping (objects 0x1600/0x1601, 0x1A00-0x1A03, static: CiA 301
//! §7.4.8.2 allows a device with fixed mapping, whose mapping entries are
//! then read-only). It reproduces the byte layouts the hub had before it
//! spoke CANopen, so `firmware/thermcomp.dbc` still decodes every frame:
//!
//! | PDO | COB-ID | mapped objects (bits) | = frame |
//! |---|---|---|---|
//! | TPDO1 | 0x180 + node | 0x2100:1..3 (16 each), 0x2101 (8), 0x2102 (8) | HUB_OFFSETS |
//! | TPDO2 | 0x280 + node | 0x2103 (16), 0x2104 (24), 0x2105 (8), 0x2106 (8), 0x2102 (8) | HUB_STATUS |
//! | TPDO3 | 0x380 + node | 0x2100:4 (16), dummy UNSIGNED32, 0x2101 (8), 0x2102 (8) | HUB_OFFSETS_EXT |
//! | TPDO4 | 0x480 + node | 0x2107:1 (32), 0x2107:2 (16), 0x2107:3 (8), 0x2102 (8) | HUB_SLOPE |
//! | RPDO1 | 0x200 + node | 0x2200:1 (32), 0x2200:2 (16), dummy UNSIGNED16 | CNC_SPINDLE |
//! | RPDO2 | 0x300 + node | 0x2201:1 (32), 0x2201:2 (32) | CNC_TOOL_POSITION |
//!
//! The values going into the process objects are quantised exactly as
//! `can_frames` does (0.1 um, saturating), and a test checks that every
//! TPDO equals the `can_frames` encoder's frame for the same report.
//! TPDO3 goes only with a fourth model output, TPDO4 once per positional
//! output (the node sets 0x2107 to that output before each): event-driven
//! transmission (type 254), once per sample.

use crate::can_frames::{quantise, StatusInfo, FAULTY_MASK_BITS, OFFSET_UM_PER_BIT};
use crate::can_frames::{REFERENCE_MM_PER_BIT, SLOPE_UM_PER_M_PER_BIT, STATUS_MAX_INPUT_COUNT};
use crate::can_rx::{
    RxMessage, Spindle, ToolPosition, NOT_AVAILABLE_I16, NOT_AVAILABLE_I32, POSITION_MM_PER_BIT,
    POWER_KW_PER_BIT, SPEED_RPM_PER_BIT, TOOL_MM_PER_BIT,
};
use crate::report::Report;

use super::od::{self, Dictionary};

/// Mapping objects of TPDO1..4.
pub const TPDO_MAPPING: [u16; 4] = [0x1A00, 0x1A01, 0x1A02, 0x1A03];
/// Mapping objects of RPDO1..2.
pub const RPDO_MAPPING: [u16; 2] = [0x1600, 0x1601];

/// Why an RPDO was not processed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum PdoError {
    /// Fewer bytes than the mapping needs (CiA 301 §7.2.2.2: not
    /// processed, EMCY 0x8210).
    TooShort {
        /// Bytes the mapping needs.
        needed: u8,
        /// Bytes received.
        found: u8,
    },
}

impl core::fmt::Display for PdoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort { needed, found } => {
                write!(f, "RPDO of {found} bytes, its mapping needs {needed}")
            }
        }
    }
}

impl core::error::Error for PdoError {}

/// The mapping entries of a PDO (sub 1..=sub 0).
fn entries(od: &Dictionary, mapping: u16) -> impl Iterator<Item = u32> + '_ {
    let n = od.get(mapping, 0) as u8;
    (1..=n).map(move |sub| od.get(mapping, sub))
}

fn split(entry: u32) -> (u16, u8, usize) {
    (
        (entry >> 16) as u16,
        (entry >> 8) as u8,
        (entry & 0xFF) as usize / 8,
    )
}

/// The bytes of the PDO whose mapping object is `mapping` (unused tail zero)
/// and how many there are.
pub fn pack(od: &Dictionary, mapping: u16) -> ([u8; 8], usize) {
    let mut out = [0u8; 8];
    let mut at = 0;
    for e in entries(od, mapping) {
        let (index, sub, len) = split(e);
        // A dummy entry (index < 0x1000, CiA 301 §7.4.8.2) sends zeros.
        let raw = if index < 0x1000 {
            0
        } else {
            od.get(index, sub)
        };
        let bytes = raw.to_le_bytes();
        if let (Some(dst), Some(src)) = (out.get_mut(at..at + len), bytes.get(..len)) {
            dst.copy_from_slice(src);
        }
        at += len;
    }
    (out, at.min(8))
}

/// Writes an RPDO's bytes into the objects its mapping names (dummy
/// entries skipped). Extra bytes are ignored (§7.2.2.2).
pub fn unpack(od: &mut Dictionary, mapping: u16, data: &[u8]) -> Result<(), PdoError> {
    let needed: usize = entries(od, mapping).map(|e| split(e).2).sum();
    if data.len() < needed {
        return Err(PdoError::TooShort {
            needed: u8::try_from(needed).unwrap_or(u8::MAX),
            found: u8::try_from(data.len()).unwrap_or(u8::MAX),
        });
    }
    let mut at = 0;
    let list: heapless::Vec<u32, 8> = entries(od, mapping).collect();
    for e in list {
        let (index, sub, len) = split(e);
        if index >= 0x1000 {
            let mut b = [0u8; 4];
            if let (Some(dst), Some(src)) = (b.get_mut(..len), data.get(at..at + len)) {
                dst.copy_from_slice(src);
            }
            let mut raw = u32::from_le_bytes(b);
            if len == 2 {
                // INTEGER16 stored sign-extended (`od`).
                raw = i32::from(i16::from_le_bytes([b[0], b[1]])) as u32;
            }
            od.set(index, sub, raw);
        }
        at += len;
    }
    Ok(())
}

fn offset_raw(um: f64) -> u32 {
    quantise(
        um,
        OFFSET_UM_PER_BIT,
        i64::from(i16::MIN),
        i64::from(i16::MAX),
    ) as i32 as u32
}

/// The report's values into the process objects (0x2100-0x2106), as
/// `can_frames` quantises them.
pub fn set_report(od: &mut Dictionary, report: &Report, info: &StatusInfo) {
    for sub in 1..=4u8 {
        let v = report
            .offsets
            .get(usize::from(sub - 1))
            .copied()
            .unwrap_or(0.0);
        od.set(od::OFFSETS, sub, offset_raw(v));
    }
    od.set(od::HUB_STATE, 0, u32::from(report.state.code()));
    od.set(
        od::COUNTER,
        0,
        u32::from(crate::can_frames::counter(report)),
    );
    od.set(od::STATUS_FLAGS, 0, u32::from(report.flags.0));
    let mask = report.faulty_channels & ((1u32 << FAULTY_MASK_BITS) - 1);
    od.set(od::FAULTY_CHANNELS, 0, mask);
    let inputs = info.n_inputs.min(STATUS_MAX_INPUT_COUNT) as u32;
    let outputs = u32::from(report.n_outputs.min(7));
    od.set(od::MODEL_SHAPE, 0, inputs | outputs << 5);
    od.set(od::CONSECUTIVE_FAULTS, 0, info.consecutive_faults.min(255));
}

/// One positional output's slope into 0x2107, for the next TPDO4.
pub fn set_slope(od: &mut Dictionary, slope_um_per_m: f64, reference_mm: f64, output: u8) {
    let slope = quantise(
        slope_um_per_m,
        SLOPE_UM_PER_M_PER_BIT,
        i64::from(i32::MIN),
        i64::from(i32::MAX),
    );
    let reference = quantise(
        reference_mm,
        REFERENCE_MM_PER_BIT,
        i64::from(i16::MIN),
        i64::from(i16::MAX),
    );
    od.set(od::SLOPE, 1, slope as i32 as u32);
    od.set(od::SLOPE, 2, reference as i32 as u32);
    od.set(od::SLOPE, 3, u32::from(output));
}

fn value_i32(raw: u32, scale: f64) -> Option<f64> {
    let v = raw as i32;
    (v != NOT_AVAILABLE_I32).then(|| f64::from(v) * scale)
}

fn value_i16(raw: u32, scale: f64) -> Option<f64> {
    let v = raw as i32 as i16;
    (v != NOT_AVAILABLE_I16).then(|| f64::from(v) * scale)
}

/// The CNC's values as the objects 0x2200 (`index` = [`od::SPINDLE`]) or
/// 0x2201 hold them, for `cnc_inputs` (largest raw value: not available).
pub fn cnc_message(od: &Dictionary, index: u16) -> Option<RxMessage> {
    match index {
        od::SPINDLE => Some(RxMessage::Spindle(Spindle {
            speed_rpm: value_i32(od.get(index, 1), SPEED_RPM_PER_BIT),
            power_kw: value_i16(od.get(index, 2), POWER_KW_PER_BIT),
        })),
        od::TOOL_POSITION => Some(RxMessage::ToolPosition(ToolPosition {
            tool_mm: value_i32(od.get(index, 1), TOOL_MM_PER_BIT),
            position_mm: value_i32(od.get(index, 2), POSITION_MM_PER_BIT),
        })),
        _ => None,
    }
}

/// [`cnc_message`] with the signal of subindex `sub` only (the other "not
/// available"): an SDO write delivers what it wrote, and never re-delivers
/// the record's other signal as if it had just arrived (an old axis
/// position, refreshed by a tool-length write).
pub fn cnc_message_sub(od: &Dictionary, index: u16, sub: u8) -> Option<RxMessage> {
    let mut msg = cnc_message(od, index)?;
    let keep = |v: &mut Option<f64>, own: u8| {
        if sub != own {
            *v = None;
        }
    };
    match &mut msg {
        RxMessage::Spindle(m) => {
            keep(&mut m.speed_rpm, 1);
            keep(&mut m.power_kw, 2);
        }
        RxMessage::ToolPosition(m) => {
            keep(&mut m.tool_mm, 1);
            keep(&mut m.position_mm, 2);
        }
    }
    Some(msg)
}
