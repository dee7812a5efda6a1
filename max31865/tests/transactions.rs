//! Exact-bytes tests of every bus transaction the driver makes, against
//! `embedded-hal-mock` SPI scripts. Each script is one chip-select frame per
//! `frame(..)`/`read(..)`; the mock panics on any byte or frame that differs
//! from the script, and `done()` fails if a scripted frame was not used.
//!
//! Register facts used (datasheet 19-6478, Tables 1-2): write address =
//! read address | 0x80; configuration bits D7 VBIAS 0x80, D6 auto 0x40,
//! D5 1-shot 0x20, D4 3-wire 0x10, D3..D2 fault cycle 0x0C, D1 fault clear
//! 0x02, D0 50 Hz 0x01.

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::delay::{CheckedDelay, Transaction as Delay};
use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
use max31865::{
    Config, Error, FaultStatus, Filter, Max31865, Mode, RtdCode, Thresholds, Wires, BIAS_SETTLE_US,
    FAULT_CYCLE_MAX_POLLS,
};

/// One chip-select frame writing `bytes`.
fn frame(bytes: &[u8]) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(bytes.to_vec()),
        T::transaction_end(),
    ]
}

/// One chip-select frame: read address `address`, then `response` clocked
/// in from MISO.
fn read(address: u8, response: &[u8]) -> Vec<T<u8>> {
    vec![
        T::transaction_start(),
        T::write_vec(vec![address]),
        T::read_vec(response.to_vec()),
        T::transaction_end(),
    ]
}

fn script(parts: &[Vec<T<u8>>]) -> Vec<T<u8>> {
    parts.concat()
}

/// Auto mode, 4-wire, 50 Hz: resting configuration 0xC1 (VBIAS 0x80 +
/// auto 0x40 + 50 Hz 0x01).
const AUTO_4W_50: Config = Config::new(Wires::Four, Filter::Hz50, Mode::Auto);
/// One-shot, 4-wire, 50 Hz: resting configuration 0x01 (VBIAS off).
const ONESHOT_4W_50: Config = Config::new(Wires::Four, Filter::Hz50, Mode::OneShot);

/// The init script for [`AUTO_4W_50`] with the full-range window.
fn init_auto() -> Vec<T<u8>> {
    script(&[
        // Thresholds from 83h: high 0x7FFF << 1 = FFFEh, low 0000h.
        frame(&[0x83, 0xFF, 0xFE, 0x00, 0x00]),
        // Configuration 0xC1 plus Fault Status Clear 0x02.
        frame(&[0x80, 0xC3]),
        // Read-back: the clear bit self-clears, so the chip holds 0xC1.
        read(0x00, &[0xC1]),
        read(0x03, &[0xFF, 0xFE, 0x00, 0x00]),
    ])
}

fn init_one_shot() -> Vec<T<u8>> {
    script(&[
        frame(&[0x83, 0xFF, 0xFE, 0x00, 0x00]),
        frame(&[0x80, 0x03]),
        read(0x00, &[0x01]),
        read(0x03, &[0xFF, 0xFE, 0x00, 0x00]),
    ])
}

#[test]
fn init_writes_thresholds_then_config_then_reads_back() {
    let mut spi = Mock::new(&init_auto());
    let dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    assert_eq!(dev.config(), AUTO_4W_50);
    spi.done();
}

/// Table 9 window for a PT100 on 400 Ω: low at -200 °C (0BDAh, code 1517),
/// high at 250 °C (7C3Ah, code 15901); 3-wire, 60 Hz, one-shot gives
/// configuration 0x10 (D4), 0x12 with the clear bit.
#[test]
fn init_one_shot_three_wire_with_window() {
    let window =
        Thresholds::new(RtdCode::new(1517).unwrap(), RtdCode::new(15901).unwrap()).unwrap();
    let config = Config::new(Wires::Three, Filter::Hz60, Mode::OneShot).with_thresholds(window);
    let mut spi = Mock::new(&script(&[
        frame(&[0x83, 0x7C, 0x3A, 0x0B, 0xDA]),
        frame(&[0x80, 0x12]),
        read(0x00, &[0x10]),
        read(0x03, &[0x7C, 0x3A, 0x0B, 0xDA]),
    ]));
    Max31865::new(spi.clone(), config).unwrap();
    spi.done();
}

/// D0 of the threshold LSBs is don't-care: a chip that reads the high LSB
/// back as FFh (its power-on value) instead of FEh still verifies.
#[test]
fn init_ignores_threshold_lsb_d0() {
    let mut spi = Mock::new(&script(&[
        frame(&[0x83, 0xFF, 0xFE, 0x00, 0x00]),
        frame(&[0x80, 0xC3]),
        read(0x00, &[0xC1]),
        read(0x03, &[0xFF, 0xFF, 0x00, 0x01]),
    ]));
    Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    spi.done();
}

/// No chip, MISO pulled high: the configuration reads 0xFF, whose D3..D2
/// (fault cycle running) can never match, so init stops right there.
#[test]
fn init_missing_chip_miso_high() {
    let mut spi = Mock::new(&script(&[
        frame(&[0x83, 0xFF, 0xFE, 0x00, 0x00]),
        frame(&[0x80, 0xC3]),
        read(0x00, &[0xFF]),
    ]));
    let err = Max31865::new(spi.clone(), AUTO_4W_50).unwrap_err();
    assert_eq!(
        err,
        Error::ConfigMismatch {
            register: 0x00,
            wrote: 0xC1,
            read: 0xFF
        }
    );
    spi.done();
}

/// No chip, MISO pulled low, with the one configuration byte that is 0x00
/// (2-wire, 60 Hz, one-shot): the configuration "matches", but the high
/// threshold MSB (FFh written) reads 00h. `low < high` guarantees some
/// threshold byte is non-zero.
#[test]
fn init_missing_chip_miso_low() {
    let config = Config::new(Wires::Two, Filter::Hz60, Mode::OneShot);
    let mut spi = Mock::new(&script(&[
        frame(&[0x83, 0xFF, 0xFE, 0x00, 0x00]),
        frame(&[0x80, 0x02]),
        read(0x00, &[0x00]),
        read(0x03, &[0x00, 0x00, 0x00, 0x00]),
    ]));
    let err = Max31865::new(spi.clone(), config).unwrap_err();
    assert_eq!(
        err,
        Error::ConfigMismatch {
            register: 0x03,
            wrote: 0xFF,
            read: 0x00
        }
    );
    spi.done();
}

/// A chip that browned out is back at its power-on configuration 00h;
/// `verify_config` reports it.
#[test]
fn verify_config_detects_reset_chip() {
    let mut spi = Mock::new(&script(&[init_auto(), read(0x00, &[0x00])]));
    let mut dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    assert_eq!(
        dev.verify_config(),
        Err(Error::ConfigMismatch {
            register: 0x00,
            wrote: 0xC1,
            read: 0x00
        })
    );
    spi.done();
}

/// RTD registers 3Ah 8Eh: word 0x3A8E = 14990, fault bit 0, code 14990 >> 1
/// = 7495 (0x1D47); with 400 Ω that is 7495 / 32768 · 400 = 91.49 Ω, about
/// -21.7 °C for a PT100 (Table 9: -20 °C is 3AFCh).
#[test]
fn read_code_example() {
    let mut spi = Mock::new(&script(&[init_auto(), read(0x01, &[0x3A, 0x8E])]));
    let mut dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    assert_eq!(dev.read_code().unwrap().value(), 7495);
    spi.done();
}

/// Datasheet Table 9: PT100 at 0 °C = 100 Ω, R_ref 400 Ω: registers 40h 00h,
/// code 100 / 400 · 2^15 = 8192 = 0x2000.
#[test]
fn read_code_datasheet_zero_celsius() {
    let mut spi = Mock::new(&script(&[init_auto(), read(0x01, &[0x40, 0x00])]));
    let mut dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    assert_eq!(dev.read_code().unwrap(), RtdCode::new(0x2000).unwrap());
    spi.done();
}

/// An open element reads full scale FFh FFh: D0 = 1, so the driver reads
/// Fault Status (07h) in a second frame; 0x80 = RTD High Threshold (code
/// 0x7FFF >= high threshold 0x7FFF).
#[test]
fn read_code_with_fault_bit_reads_fault_status() {
    let mut spi = Mock::new(&script(&[
        init_auto(),
        read(0x01, &[0xFF, 0xFF]),
        read(0x07, &[0x80]),
    ]));
    let mut dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    let err = dev.read_code().unwrap_err();
    assert_eq!(err, Error::Fault(FaultStatus::from_bits(0x80)));
    match err {
        Error::Fault(status) => {
            assert!(status.rtd_high_threshold());
            assert!(!status.rtd_low_threshold());
        }
        other => panic!("expected a fault, got {other:?}"),
    }
    spi.done();
}

/// Clearing writes the resting configuration with D1: 0xC1 | 0x02 = 0xC3
/// (D5, D3, D2 are 0, as the datasheet requires for a clear).
#[test]
fn clear_fault_write() {
    let mut spi = Mock::new(&script(&[init_auto(), frame(&[0x80, 0xC3])]));
    let mut dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    dev.clear_fault().unwrap();
    spi.done();
}

/// One-shot start in 4-wire 50 Hz: VBIAS 0x80 | 1-Shot 0x20 | 50 Hz 0x01 =
/// 0xA1. VBIAS stays on afterwards, so a later clear writes 0x83, not 0x03.
#[test]
fn start_conversion_sets_one_shot_and_vbias() {
    let mut spi = Mock::new(&script(&[
        init_one_shot(),
        frame(&[0x80, 0xA1]),
        frame(&[0x80, 0x83]),
    ]));
    let mut dev = Max31865::new(spi.clone(), ONESHOT_4W_50).unwrap();
    dev.start_conversion().unwrap();
    dev.clear_fault().unwrap();
    spi.done();
}

/// 1-Shot and VBIAS switching are meaningless in Auto mode: refused before
/// any byte goes out (the script has nothing after init).
#[test]
fn one_shot_calls_refused_in_auto_mode() {
    let mut spi = Mock::new(&init_auto());
    let mut dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    assert_eq!(dev.start_conversion(), Err(Error::WrongMode));
    assert_eq!(dev.set_bias(false), Err(Error::WrongMode));
    let mut delay = CheckedDelay::new(&[]);
    assert_eq!(
        dev.read_one_shot(&mut delay, BIAS_SETTLE_US),
        Err(Error::WrongMode)
    );
    delay.done();
    spi.done();
}

/// The blocking sequence: VBIAS on (0x81), wait 10.5 ms, 1-Shot (0xA1),
/// wait the 50 Hz one-shot maximum 66 ms, read, VBIAS off (0x01).
#[test]
fn read_one_shot_sequence() {
    let mut spi = Mock::new(&script(&[
        init_one_shot(),
        frame(&[0x80, 0x81]),
        frame(&[0x80, 0xA1]),
        read(0x01, &[0x40, 0x00]),
        frame(&[0x80, 0x01]),
    ]));
    let mut delay = CheckedDelay::new(&[Delay::delay_us(10_500), Delay::delay_us(66_000)]);
    let mut dev = Max31865::new(spi.clone(), ONESHOT_4W_50).unwrap();
    assert_eq!(
        dev.read_one_shot(&mut delay, BIAS_SETTLE_US)
            .unwrap()
            .value(),
        8192
    );
    delay.done();
    spi.done();
}

/// A faulted one-shot still switches VBIAS off before returning the fault
/// (0x40 = RTD Low Threshold: a shorted element reads code 0).
#[test]
fn read_one_shot_fault_still_switches_bias_off() {
    let mut spi = Mock::new(&script(&[
        init_one_shot(),
        frame(&[0x80, 0x81]),
        frame(&[0x80, 0xA1]),
        read(0x01, &[0x00, 0x01]),
        read(0x07, &[0x40]),
        frame(&[0x80, 0x01]),
    ]));
    let mut delay = CheckedDelay::new(&[Delay::delay_us(2_000), Delay::delay_us(66_000)]);
    let mut dev = Max31865::new(spi.clone(), ONESHOT_4W_50).unwrap();
    assert_eq!(
        dev.read_one_shot(&mut delay, 2_000),
        Err(Error::Fault(FaultStatus::from_bits(0x40)))
    );
    delay.done();
    spi.done();
}

/// Automatic fault detection from Auto mode: clear (0xC3), then
/// `100X_010Xb` = VBIAS 0x80 | cycle 0x04 | 50 Hz 0x01 = 0x85; poll until
/// D3..D2 read 00 (0x85 still running, then 0x81 done); read Fault Status
/// (0x00 = wiring good); restore 0xC1 to resume auto conversions.
#[test]
fn fault_detection_cycle_clean() {
    let mut spi = Mock::new(&script(&[
        init_auto(),
        frame(&[0x80, 0xC3]),
        frame(&[0x80, 0x85]),
        read(0x00, &[0x85]),
        read(0x00, &[0x81]),
        read(0x07, &[0x00]),
        frame(&[0x80, 0xC1]),
    ]));
    let mut delay = CheckedDelay::new(&[Delay::delay_us(100), Delay::delay_us(100)]);
    let mut dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    assert_eq!(
        dev.run_fault_detection(&mut delay).unwrap(),
        FaultStatus::empty()
    );
    delay.done();
    spi.done();
}

/// 3-wire one-shot (resting 0x10): the cycle byte keeps D4 and sets VBIAS:
/// 0x94. The status 0x20 (REFIN- > 0.85 VBIAS) is the open-element case of
/// Table 11; restoring writes 0x10, i.e. VBIAS back off.
#[test]
fn fault_detection_cycle_finds_open_rtd() {
    let config = Config::new(Wires::Three, Filter::Hz60, Mode::OneShot);
    let mut spi = Mock::new(&script(&[
        frame(&[0x83, 0xFF, 0xFE, 0x00, 0x00]),
        frame(&[0x80, 0x12]),
        read(0x00, &[0x10]),
        read(0x03, &[0xFF, 0xFE, 0x00, 0x00]),
        frame(&[0x80, 0x12]),
        frame(&[0x80, 0x94]),
        read(0x00, &[0x90]),
        read(0x07, &[0x20]),
        frame(&[0x80, 0x10]),
    ]));
    let mut delay = CheckedDelay::new(&[Delay::delay_us(100)]);
    let mut dev = Max31865::new(spi.clone(), config).unwrap();
    let status = dev.run_fault_detection(&mut delay).unwrap();
    assert!(status.refin_high());
    assert_eq!(status.bits(), 0x20);
    delay.done();
    spi.done();
}

/// A cycle that never finishes: after FAULT_CYCLE_MAX_POLLS polls the
/// driver restores the configuration and reports a timeout.
#[test]
fn fault_detection_cycle_timeout() {
    let mut parts = vec![init_auto(), frame(&[0x80, 0xC3]), frame(&[0x80, 0x85])];
    let mut delays = Vec::new();
    for _ in 0..FAULT_CYCLE_MAX_POLLS {
        parts.push(read(0x00, &[0x85]));
        delays.push(Delay::delay_us(100));
    }
    parts.push(frame(&[0x80, 0xC1]));
    let mut spi = Mock::new(&script(&parts));
    let mut delay = CheckedDelay::new(&delays);
    let mut dev = Max31865::new(spi.clone(), AUTO_4W_50).unwrap();
    assert_eq!(dev.run_fault_detection(&mut delay), Err(Error::Timeout));
    delay.done();
    spi.done();
}

#[test]
fn release_returns_the_bus() {
    let spi = Mock::new(&init_auto());
    let dev = Max31865::new(spi, AUTO_4W_50).unwrap();
    let mut spi = dev.release();
    spi.done();
}

/// An SPI device whose every transfer fails.
#[derive(Debug)]
struct BrokenBus;

impl ErrorType for BrokenBus {
    type Error = ErrorKind;
}

impl SpiDevice for BrokenBus {
    fn transaction(&mut self, _: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        Err(ErrorKind::ModeFault)
    }
}

/// Bus errors come back wrapped, unchanged.
#[test]
fn bus_error_is_wrapped() {
    let err = Max31865::new(BrokenBus, AUTO_4W_50).unwrap_err();
    assert_eq!(err, Error::Spi(ErrorKind::ModeFault));
}
