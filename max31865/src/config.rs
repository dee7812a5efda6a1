//! Configuration values: wiring, mains filter, conversion mode, fault
//! thresholds, and the 15-bit [`RtdCode`] they are expressed in.

use crate::register as reg;

/// How the RTD is wired to the chip (Configuration D4, "3-Wire").
///
/// Two- and four-wire connections use the same setting (D4 = 0); they
/// differ only in the board's jumpers/wiring. Three-wire (D4 = 1) makes the
/// chip subtract the FORCE+ to RTDIN+ lead drop to cancel the resistance of
/// the shared FORCE-/RTDIN- lead.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Wires {
    /// 2-wire RTD: lead resistance adds to the reading.
    Two,
    /// 3-wire RTD: one lead's drop is subtracted (D4 = 1).
    Three,
    /// 4-wire (Kelvin) RTD: force and sense leads separate.
    Four,
}

/// Mains-rejection notch of the ADC's digital filter (Configuration D0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Filter {
    /// Reject 50 Hz and harmonics (D0 = 1); slower conversions.
    Hz50,
    /// Reject 60 Hz and harmonics (D0 = 0, the power-on default).
    Hz60,
}

/// Conversion mode (Configuration D6, with D7 VBIAS).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// "Normally Off": VBIAS off between conversions (less self-heating of
    /// the element); each conversion is started with the 1-Shot bit.
    OneShot,
    /// Continuous conversions at the filter's 50/60 Hz rate with VBIAS
    /// always on; [`crate::Max31865::read_code`] returns the latest result.
    Auto,
}

/// A 15-bit RTD resistance ratio code: `R_rtd / R_ref = code / 2^15`
/// (datasheet Tables 4 and 5).
///
/// The same format is used for the RTD data (01h..02h) and for both fault
/// thresholds (03h..06h): the code sits in D15..D1 of the 16-bit register
/// word and D0 is the fault bit (data) or don't-care (thresholds).
///
/// With the datasheet's PT100 example (Table 9, `R_ref` = 400 Ω), 0 °C =
/// 100 Ω gives `100 / 400 · 32768 = 8192` (0x2000, register word 0x4000).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RtdCode(u16);

impl RtdCode {
    /// Number of codes, 2^15: the code that would mean `R_rtd = R_ref`
    /// (never reached; the top code is [`RtdCode::MAX`]).
    pub const FULL_SCALE: u32 = 1 << 15;
    /// Code 0 (`R_rtd` = 0, a shorted element).
    pub const MIN: Self = Self(0);
    /// Top code 0x7FFF (`R_rtd` ≥ 0.99997 · `R_ref`, an open element).
    pub const MAX: Self = Self(0x7FFF);

    /// A code from its value; `None` if it does not fit in 15 bits.
    pub const fn new(code: u16) -> Option<Self> {
        if code <= Self::MAX.0 {
            Some(Self(code))
        } else {
            None
        }
    }

    /// The code from a 16-bit register word (MSB register first): the code
    /// is `word >> 1`; D0 (fault bit or don't-care) is dropped.
    pub const fn from_register_word(word: u16) -> Self {
        Self(word >> 1)
    }

    /// The 16-bit register word for this code, with D0 = 0.
    pub const fn to_register_word(self) -> u16 {
        self.0 << 1
    }

    /// The code's value, `0..=0x7FFF`.
    pub const fn value(self) -> u16 {
        self.0
    }
}

impl From<RtdCode> for u16 {
    fn from(code: RtdCode) -> u16 {
        code.0
    }
}

impl From<RtdCode> for u32 {
    fn from(code: RtdCode) -> u32 {
        u32::from(code.0)
    }
}

/// The RTD fault window: the chip latches "RTD High Threshold" when a
/// conversion result is `>= high` and "RTD Low Threshold" when it is
/// `<= low` (datasheet, "Fault Threshold Registers (03h-06h)").
///
/// Built only through [`Thresholds::new`], which requires `low < high`.
/// Besides rejecting a window that faults every reading, this is what makes
/// the read-back in [`crate::Max31865::new`] always catch a stuck MISO line:
/// an all-0x00 bus would need `high = 0` and an all-0xFF bus `low = 0x7FFF`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Thresholds {
    low: RtdCode,
    high: RtdCode,
}

impl Thresholds {
    /// The widest window, `low = 0`, `high = 0x7FFF`: only a shorted
    /// (code 0) or open (top code) element trips it. Close to the power-on
    /// values (low 0000h, high FFFFh).
    pub const FULL_RANGE: Self = Self {
        low: RtdCode::MIN,
        high: RtdCode::MAX,
    };

    /// A window from its limits; `None` unless `low < high`.
    pub const fn new(low: RtdCode, high: RtdCode) -> Option<Self> {
        if low.0 < high.0 {
            Some(Self { low, high })
        } else {
            None
        }
    }

    /// The lower limit (faults at or below it).
    pub const fn low(self) -> RtdCode {
        self.low
    }

    /// The upper limit (faults at or above it).
    pub const fn high(self) -> RtdCode {
        self.high
    }

    /// The four bytes written from address 83h on: High MSB, High LSB,
    /// Low MSB, Low LSB (D0 of each LSB written as 0).
    pub(crate) const fn register_bytes(self) -> [u8; 4] {
        let h = self.high.to_register_word().to_be_bytes();
        let l = self.low.to_register_word().to_be_bytes();
        [h[0], h[1], l[0], l[1]]
    }
}

/// Everything [`crate::Max31865::new`] writes to the chip.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// RTD wiring.
    pub wires: Wires,
    /// Mains notch filter.
    pub filter: Filter,
    /// Conversion mode.
    pub mode: Mode,
    /// Fault window compared against every conversion.
    pub thresholds: Thresholds,
}

impl Config {
    /// A configuration with the [`Thresholds::FULL_RANGE`] window.
    pub const fn new(wires: Wires, filter: Filter, mode: Mode) -> Self {
        Self {
            wires,
            filter,
            mode,
            thresholds: Thresholds::FULL_RANGE,
        }
    }

    /// The same configuration with another fault window.
    pub const fn with_thresholds(self, thresholds: Thresholds) -> Self {
        Self { thresholds, ..self }
    }

    /// The resting value of the configuration register: VBIAS and D6 set
    /// in [`Mode::Auto`] (in [`Mode::OneShot`] VBIAS starts off), D4 for
    /// three wires, D0 for 50 Hz; 1-Shot, the fault-cycle bits and Fault
    /// Status Clear are 0.
    pub const fn register_byte(self) -> u8 {
        let mode = match self.mode {
            Mode::Auto => reg::CFG_VBIAS | reg::CFG_AUTO,
            Mode::OneShot => 0,
        };
        let wires = match self.wires {
            Wires::Three => reg::CFG_THREE_WIRE,
            Wires::Two | Wires::Four => 0,
        };
        let filter = match self.filter {
            Filter::Hz50 => reg::CFG_FILTER_50HZ,
            Filter::Hz60 => 0,
        };
        mode | wires | filter
    }
}

/// Worst-case wait after starting a conversion before its result is
/// ready, in µs (datasheet Electrical Characteristics, conversion time
/// t_CONV, maximum):
///
/// | mode | 60 Hz | 50 Hz |
/// |---|---|---|
/// | [`Mode::OneShot`] (typ. 52 ms / 62.5 ms) | 55 000 | 66 000 |
/// | [`Mode::Auto`], one period (typ. 16.7 ms / 20 ms) | 17 600 | 21 000 |
///
/// The 21 ms figure is the "21ms (max) Conversion Time" of the data
/// sheet's feature list. A one-shot conversion is slower because the
/// filter has to settle from scratch.
pub const fn conversion_time_us(filter: Filter, mode: Mode) -> u32 {
    match (mode, filter) {
        (Mode::OneShot, Filter::Hz60) => 55_000,
        (Mode::OneShot, Filter::Hz50) => 66_000,
        (Mode::Auto, Filter::Hz60) => 17_600,
        (Mode::Auto, Filter::Hz50) => 21_000,
    }
}

/// Default wait after switching VBIAS on before a 1-shot conversion, in
/// µs. The datasheet (1-Shot (D5) description) asks for at least 10.5 time
/// constants of the RTD input filter; this default assumes τ ≤ 1 ms
/// (e.g. 10 kΩ · 100 nF). The typical application circuit (C_I = 100 nF
/// for a PT100, 10 nF for a PT1000, with resistances of a few hundred Ω to
/// a few kΩ) is well inside that; recompute it for your input filter and
/// pass your own value to [`crate::Max31865::read_one_shot`].
pub const BIAS_SETTLE_US: u32 = 10_500;
