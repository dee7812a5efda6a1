//! Unit tests of the pure parts: register bytes and decoding. The bus
//! transactions are tested in `tests/transactions.rs`.

extern crate std;

use std::format;
use std::string::ToString;

use proptest::prelude::*;

use super::*;

/// Each Fault Status bit decodes to exactly its own accessor (datasheet
/// Table 7: D7 high threshold .. D2 over/undervoltage), and D1..D0 are
/// ignored.
#[test]
fn fault_status_single_bits_table() {
    type Accessor = fn(FaultStatus) -> bool;
    let accessors: [(u8, Accessor); 6] = [
        (0x80, FaultStatus::rtd_high_threshold),
        (0x40, FaultStatus::rtd_low_threshold),
        (0x20, FaultStatus::refin_high),
        (0x10, FaultStatus::refin_low_force_open),
        (0x08, FaultStatus::rtdin_low_force_open),
        (0x04, FaultStatus::over_under_voltage),
    ];
    for (bit, _) in accessors {
        let status = FaultStatus::from_bits(bit);
        for (other, accessor) in accessors {
            assert_eq!(
                accessor(status),
                bit == other,
                "raw {bit:#04x}, accessor for {other:#04x}"
            );
        }
        assert!(!status.is_empty());
    }
    // D1..D0 are unused: a register reading 0x03 reports no fault.
    assert!(FaultStatus::from_bits(0x03).is_empty());
    assert_eq!(FaultStatus::from_bits(0x03), FaultStatus::empty());
}

/// An open PT100 element with the full-range window reads full scale and
/// (datasheet Table 12) sets D7 and, in the detection cycle, D5: 0xA0.
#[test]
fn fault_status_open_element_example() {
    let status = FaultStatus::from_bits(0xA0);
    assert!(status.rtd_high_threshold());
    assert!(status.refin_high());
    assert!(!status.rtd_low_threshold());
    assert_eq!(
        status.to_string(),
        "RTD high threshold, REFIN- > 0.85 VBIAS"
    );
    assert_eq!(
        format!("{status:?}"),
        "FaultStatus(0xa0: RTD high threshold, REFIN- > 0.85 VBIAS)"
    );
    assert_eq!(FaultStatus::empty().to_string(), "none");
}

proptest! {
    /// For every raw byte: `bits()` is the byte without D1..D0, and each
    /// accessor equals its bit.
    #[test]
    fn fault_status_decodes_every_byte(raw in any::<u8>()) {
        let s = FaultStatus::from_bits(raw);
        prop_assert_eq!(s.bits(), raw & 0xFC);
        prop_assert_eq!(s.rtd_high_threshold(), raw & 0x80 != 0);
        prop_assert_eq!(s.rtd_low_threshold(), raw & 0x40 != 0);
        prop_assert_eq!(s.refin_high(), raw & 0x20 != 0);
        prop_assert_eq!(s.refin_low_force_open(), raw & 0x10 != 0);
        prop_assert_eq!(s.rtdin_low_force_open(), raw & 0x08 != 0);
        prop_assert_eq!(s.over_under_voltage(), raw & 0x04 != 0);
        prop_assert_eq!(s.is_empty(), raw & 0xFC == 0);
        // Display lists one name per set bit.
        let text = s.to_string();
        let names = if s.is_empty() { 0 } else { text.split(", ").count() as u32 };
        prop_assert_eq!(names, s.bits().count_ones());
    }

    /// The code is the register word shifted right by one (Table 4), always
    /// fits 15 bits, and survives the threshold encoding.
    #[test]
    fn rtd_code_register_word_round_trip(word in any::<u16>()) {
        let code = RtdCode::from_register_word(word);
        prop_assert_eq!(code.value(), word >> 1);
        prop_assert!(code <= RtdCode::MAX);
        prop_assert_eq!(code.to_register_word(), word & 0xFFFE);
        prop_assert_eq!(RtdCode::new(code.value()), Some(code));
    }
}

/// Datasheet Table 9 (PT100, R_ref = 400 Ω), register word -> code:
/// -200 °C 0BDAh -> 1517, -20 °C 3AFCh -> 7550, 0 °C 4000h -> 8192,
/// 100 °C 58A4h -> 11346. And Table 5: ratio 0.999 = FFFEh -> 32767.
#[test]
fn rtd_code_datasheet_table_9() {
    for (word, code) in [
        (0x0BDA, 1517),
        (0x3AFC, 7550),
        (0x4000, 8192),
        (0x58A4, 11346),
        (0xFFFE, 32767),
    ] {
        assert_eq!(
            RtdCode::from_register_word(word).value(),
            code,
            "word {word:#06x}"
        );
    }
    // 100 Ω / 400 Ω · 2^15 = 8192 exactly.
    assert_eq!(100 * RtdCode::FULL_SCALE / 400, 8192);
}

#[test]
fn rtd_code_rejects_16_bit_values() {
    assert_eq!(RtdCode::new(0x7FFF), Some(RtdCode::MAX));
    assert_eq!(
        RtdCode::new(0x8000),
        None,
        "bit 15 does not exist in a 15-bit code"
    );
    assert_eq!(u32::from(RtdCode::MAX), 32767);
}

#[test]
fn thresholds_require_low_below_high() {
    let c = |v| RtdCode::new(v).unwrap();
    assert!(
        Thresholds::new(c(100), c(100)).is_none(),
        "empty window faults every reading"
    );
    assert!(Thresholds::new(c(200), c(100)).is_none());
    let t = Thresholds::new(c(1000), c(0x7000)).unwrap();
    assert_eq!((t.low(), t.high()), (c(1000), c(0x7000)));
    // High first (03h..04h), then low (05h..06h), code << 1 with D0 = 0:
    // 0x7000 << 1 = 0xE000, 1000 << 1 = 2000 = 0x07D0.
    assert_eq!(t.register_bytes(), [0xE0, 0x00, 0x07, 0xD0]);
    assert_eq!(
        Thresholds::FULL_RANGE.register_bytes(),
        [0xFF, 0xFE, 0x00, 0x00]
    );
}

/// Configuration register byte for every setting (datasheet Table 2):
/// D7 VBIAS + D6 auto only in Auto mode, D4 only for 3 wires, D0 only for
/// 50 Hz; 2- and 4-wire give the same byte.
#[test]
fn config_register_byte_table() {
    use Filter::*;
    use Mode::*;
    use Wires::*;
    let cases = [
        (Two, Hz60, OneShot, 0x00),
        (Four, Hz60, OneShot, 0x00),
        (Three, Hz60, OneShot, 0x10),
        (Four, Hz50, OneShot, 0x01),
        (Three, Hz50, OneShot, 0x11),
        (Two, Hz60, Auto, 0xC0),
        (Four, Hz50, Auto, 0xC1),
        (Three, Hz50, Auto, 0xD1),
        (Three, Hz60, Auto, 0xD0),
    ];
    for (wires, filter, mode, byte) in cases {
        assert_eq!(
            Config::new(wires, filter, mode).register_byte(),
            byte,
            "{wires:?} {filter:?} {mode:?}"
        );
    }
}

/// A stuck-high MISO (0xFF) can never pass the configuration compare: no
/// resting byte has D3..D2 set, and D3..D2 are compared.
#[test]
fn stuck_high_config_never_matches() {
    for wires in [Wires::Two, Wires::Three, Wires::Four] {
        for filter in [Filter::Hz50, Filter::Hz60] {
            for mode in [Mode::OneShot, Mode::Auto] {
                let byte = Config::new(wires, filter, mode).register_byte();
                assert!(check::<()>(0, byte, 0xFF, register::CFG_READBACK_MASK).is_err());
            }
        }
    }
}

#[test]
fn conversion_times_are_the_datasheet_maxima() {
    assert_eq!(conversion_time_us(Filter::Hz60, Mode::OneShot), 55_000);
    assert_eq!(conversion_time_us(Filter::Hz50, Mode::OneShot), 66_000);
    assert_eq!(conversion_time_us(Filter::Hz50, Mode::Auto), 21_000);
    // Each maximum is above the typical 52 / 62.5 / 20 ms.
    assert!(conversion_time_us(Filter::Hz60, Mode::OneShot) > 52_000);
}

#[test]
fn error_display() {
    let e: Error<u8> = Error::ConfigMismatch {
        register: 0,
        wrote: 0xC1,
        read: 0x00,
    };
    assert_eq!(
        e.to_string(),
        "MAX31865: register 0x00 wrote 0xc1, read back 0x00 (chip missing or not responding?)"
    );
    let f: Error<u8> = Error::Fault(FaultStatus::from_bits(0x40));
    assert_eq!(f.to_string(), "MAX31865: RTD fault: RTD low threshold");
    // `Error<E>` is `Copy` when `E` is.
    let g = f;
    assert_eq!(f, g);
}
