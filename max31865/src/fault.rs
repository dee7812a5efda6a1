//! The Fault Status register (07h) and its decoding.

use core::fmt;

/// Contents of the Fault Status register (07h), datasheet Table 7.
///
/// The bits latch until [`crate::Max31865::clear_fault`] writes Fault Status
/// Clear, so intermittent faults are not lost between reads. D1..D0 are
/// unused and are masked off, so two statuses compare equal exactly when
/// they report the same faults. Which wiring faults set which bit is listed
/// in the datasheet's Tables 10-12 (2-, 3- and 4-wire).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct FaultStatus(u8);

impl FaultStatus {
    /// D7 "RTD High Threshold": a conversion was `>=` the high threshold
    /// (typically an open element: full-scale reading).
    pub const RTD_HIGH_THRESHOLD: u8 = 1 << 7;
    /// D6 "RTD Low Threshold": a conversion was `<=` the low threshold
    /// (typically a shorted element or RTDIN+ shorted low).
    pub const RTD_LOW_THRESHOLD: u8 = 1 << 6;
    /// D5 "REFIN- > 0.85 x V_BIAS" (fault-detection cycle; open RTD or
    /// FORCE+ open/shorted high).
    pub const REFIN_HIGH: u8 = 1 << 5;
    /// D4 "REFIN- < 0.85 x V_BIAS (FORCE- open)" (fault-detection cycle;
    /// e.g. RTDIN- or FORCE- shorted low).
    pub const REFIN_LOW_FORCE_OPEN: u8 = 1 << 4;
    /// D3 "RTDIN- < 0.85 x V_BIAS (FORCE- open)" (fault-detection cycle;
    /// e.g. RTDIN+ or RTDIN- shorted low).
    pub const RTDIN_LOW_FORCE_OPEN: u8 = 1 << 3;
    /// D2 "Overvoltage/undervoltage fault": a protected input is above VDD
    /// or below GND1.
    pub const OVER_UNDER_VOLTAGE: u8 = 1 << 2;
    /// The six defined bits, D7..D2.
    pub const MASK: u8 = 0b1111_1100;

    /// Named bits with their short names, in register order (D7 first).
    const NAMES: [(u8, &'static str); 6] = [
        (Self::RTD_HIGH_THRESHOLD, "RTD high threshold"),
        (Self::RTD_LOW_THRESHOLD, "RTD low threshold"),
        (Self::REFIN_HIGH, "REFIN- > 0.85 VBIAS"),
        (
            Self::REFIN_LOW_FORCE_OPEN,
            "REFIN- < 0.85 VBIAS (FORCE- open)",
        ),
        (
            Self::RTDIN_LOW_FORCE_OPEN,
            "RTDIN- < 0.85 VBIAS (FORCE- open)",
        ),
        (Self::OVER_UNDER_VOLTAGE, "over/undervoltage"),
    ];

    /// Decodes a raw register value; D1..D0 are ignored.
    pub const fn from_bits(raw: u8) -> Self {
        Self(raw & Self::MASK)
    }

    /// The status with no fault set.
    pub const fn empty() -> Self {
        Self(0)
    }

    /// The defined bits (D7..D2), D1..D0 always 0.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// `true` if no fault bit is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// `true` if every bit of `mask` is set.
    pub const fn contains(self, mask: u8) -> bool {
        self.0 & mask == mask
    }

    /// D7: conversion result at or above the high fault threshold.
    pub const fn rtd_high_threshold(self) -> bool {
        self.contains(Self::RTD_HIGH_THRESHOLD)
    }

    /// D6: conversion result at or below the low fault threshold.
    pub const fn rtd_low_threshold(self) -> bool {
        self.contains(Self::RTD_LOW_THRESHOLD)
    }

    /// D5: REFIN- above 0.85 · V_BIAS.
    pub const fn refin_high(self) -> bool {
        self.contains(Self::REFIN_HIGH)
    }

    /// D4: REFIN- below 0.85 · V_BIAS with the FORCE- switch open.
    pub const fn refin_low_force_open(self) -> bool {
        self.contains(Self::REFIN_LOW_FORCE_OPEN)
    }

    /// D3: RTDIN- below 0.85 · V_BIAS with the FORCE- switch open.
    pub const fn rtdin_low_force_open(self) -> bool {
        self.contains(Self::RTDIN_LOW_FORCE_OPEN)
    }

    /// D2: a protected input above VDD or below GND1.
    pub const fn over_under_voltage(self) -> bool {
        self.contains(Self::OVER_UNDER_VOLTAGE)
    }
}

impl fmt::Debug for FaultStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "FaultStatus({:#04x}: {})", self.0, self)
    }
}

/// Lists the set faults separated by `", "`, or `"none"`.
impl fmt::Display for FaultStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return f.write_str("none");
        }
        let mut first = true;
        for (bit, name) in Self::NAMES {
            if self.contains(bit) {
                if !first {
                    f.write_str(", ")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for FaultStatus {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "FaultStatus({=u8:#04x}: high={=bool} low={=bool} refin_high={=bool} refin_low={=bool} rtdin_low={=bool} ov_uv={=bool})",
            self.0,
            self.rtd_high_threshold(),
            self.rtd_low_threshold(),
            self.refin_high(),
            self.refin_low_force_open(),
            self.rtdin_low_force_open(),
            self.over_under_voltage()
        );
    }
}
