//! Register map of the MAX31865 (datasheet 19-6478, Table 1 "Register
//! Memory Map" and Table 2 "Configuration Register Definition").
//!
//! Each register has a read address `0xh` and a write address `8xh`
//! ([`WRITE`] or-ed into the read address). Data moves MSB first; after the
//! address byte the chip auto-increments the address for every further
//! byte of the same chip-select frame, for reads and for writes.

/// Configuration register (read 00h, write 80h; power-on value 00h).
pub const CONFIG: u8 = 0x00;
/// RTD MSBs (01h, read only): bits 14..7 of the 15-bit resistance ratio.
pub const RTD_MSB: u8 = 0x01;
/// RTD LSBs (02h, read only): bits 6..0 of the ratio in D7..D1; D0 is the
/// "Fault" bit, set when any bit of the Fault Status register is set.
pub const RTD_LSB: u8 = 0x02;
/// High Fault Threshold MSB (03h; power-on FFh).
pub const HIGH_FAULT_THRESHOLD_MSB: u8 = 0x03;
/// High Fault Threshold LSB (04h; power-on FFh). D0 is don't-care.
pub const HIGH_FAULT_THRESHOLD_LSB: u8 = 0x04;
/// Low Fault Threshold MSB (05h; power-on 00h).
pub const LOW_FAULT_THRESHOLD_MSB: u8 = 0x05;
/// Low Fault Threshold LSB (06h; power-on 00h). D0 is don't-care.
pub const LOW_FAULT_THRESHOLD_LSB: u8 = 0x06;
/// Fault Status (07h, read only; latched until Fault Status Clear).
pub const FAULT_STATUS: u8 = 0x07;

/// Or-ed into a register address to make it a write address (A7 = 1).
pub const WRITE: u8 = 0x80;

/// Configuration D7, "V_BIAS": 1 = bias voltage on (needed for any
/// conversion and for the fault-detection cycle).
pub const CFG_VBIAS: u8 = 1 << 7;
/// Configuration D6, "Conversion Mode": 1 = Auto (continuous conversions
/// at the filter's 50/60 Hz rate), 0 = Normally Off.
pub const CFG_AUTO: u8 = 1 << 6;
/// Configuration D5, "1-Shot": write 1 in Normally-Off mode to start one
/// conversion when CS goes high; self-clearing.
pub const CFG_ONE_SHOT: u8 = 1 << 5;
/// Configuration D4, "3-Wire": 1 = 3-wire RTD, 0 = 2-wire or 4-wire.
pub const CFG_THREE_WIRE: u8 = 1 << 4;
/// Configuration D3..D2, "Fault Detection Cycle Control" (Table 3). Read
/// back as 00 once no cycle is running.
pub const CFG_FAULT_CYCLE_MASK: u8 = 0b0000_1100;
/// D3..D2 = 01: fault detection with automatic delay (the full byte is
/// `100X_010Xb`); the chip inserts 100 µs settling delays itself.
pub const CFG_FAULT_CYCLE_AUTO: u8 = 0b0000_0100;
/// D3..D2 = 10: manual cycle 1 (`100X_100Xb`); VBIAS must already have
/// been on for 5 input time constants.
pub const CFG_FAULT_CYCLE_MANUAL_1: u8 = 0b0000_1000;
/// D3..D2 = 11: manual cycle 2 (`100X_110Xb`), written 5 time constants
/// after cycle 1.
pub const CFG_FAULT_CYCLE_MANUAL_2: u8 = 0b0000_1100;
/// Configuration D1, "Fault Status Clear": write 1 (with D5, D3, D2 = 0)
/// to return Fault Status D7..D2 to 0; self-clearing.
pub const CFG_FAULT_CLEAR: u8 = 1 << 1;
/// Configuration D0, "50/60 Hz filter select": 1 = 50 Hz, 0 = 60 Hz.
pub const CFG_FILTER_50HZ: u8 = 1 << 0;

/// Bits of the configuration register that hold their written value and
/// are compared on read-back: D7, D6, D4, D0, and D3..D2 (which must read
/// 00, "no fault-detection cycle running", after a write of 00). D5 and D1
/// are self-clearing and always read 0, so they are left out.
pub const CFG_READBACK_MASK: u8 = !(CFG_ONE_SHOT | CFG_FAULT_CLEAR);
