//! `no_std` driver for the Maxim (Analog Devices) **MAX31865**
//! RTD-to-digital converter (datasheet 19-6478), generic over
//! [`embedded_hal::spi::SpiDevice`].
//!
//! # The chip
//!
//! One MAX31865 serves one platinum RTD (PT100 or PT1000). A reference
//! resistor `R_ref` (typically 4·R0: 400 Ω for a PT100, 4 kΩ for a PT1000)
//! carries the same current as the RTD, and a delta-sigma ADC reports the
//! ratio as a 15-bit code ([`RtdCode`]):
//!
//! ```text
//! R_rtd = code / 2^15 · R_ref
//! ```
//!
//! The datasheet's Table 9 example: a PT100 at 0 °C (100 Ω) with
//! `R_ref` = 400 Ω reads `100 / 400 · 32768 = 8192` = 0x2000, i.e. register
//! bytes `40h 00h`. Turning the code into a temperature (Callendar-Van
//! Dusen) is not this crate's job: the hub does it in `model-core::rtd`.
//!
//! Every conversion is compared with two fault thresholds, and a separate
//! fault-detection cycle checks the force/sense lines against 0.85·V_BIAS;
//! results latch in the Fault Status register ([`FaultStatus`]) and raise
//! D0 of the RTD LSB register.
//!
//! # Bus transactions
//!
//! SPI mode 1 or 3, at most 5 MHz, configured on the [`SpiDevice`] by the
//! caller. Every access is one chip-select frame: an address byte (read
//! `0xh`, write `8xh`), then data, MSB first, with the address
//! auto-incrementing (see [`register`]).
//!
//! | call | bytes on MOSI (`..` = bytes read on MISO) |
//! |---|---|
//! | [`Max31865::new`] / [`Max31865::configure`] | `83 hM hL lM lL`, then `80 cfg\|02`, then `00 ..1`, then `03 ..4` |
//! | [`Max31865::read_code`] | `01 ..2`; if D0 of the second byte is set, also `07 ..1` |
//! | [`Max31865::clear_fault`] | `80 cfg\|02` |
//! | [`Max31865::start_conversion`] | `80 cfg\|A0` (VBIAS + 1-Shot) |
//! | [`Max31865::run_fault_detection`] | `80 cfg\|02`, `80 84\|(cfg&11)`, poll `00 ..1`, `07 ..1`, `80 cfg` |
//!
//! # Why read the configuration back
//!
//! SPI has no acknowledge: writes to a missing chip, or to one whose MISO
//! is unconnected, "succeed". A floating or stuck MISO reads 0x00 or 0xFF,
//! so [`Max31865::new`] reads every register it wrote and fails with
//! [`Error::ConfigMismatch`] on any difference. The check is guaranteed to
//! catch a stuck line: the configuration never has D3..D2 set (so it is
//! never read as 0xFF) and [`Thresholds`] requires `low < high` (so the
//! threshold registers are never all 0x00 nor all 0xFF). The same check,
//! [`Max31865::verify_config`], can be run periodically: after a supply
//! brown-out the chip returns to its power-on configuration (00h, no
//! conversions), which otherwise shows up only as a frozen reading.
//!
//! Thresholds are written before the configuration so that in
//! [`Mode::Auto`] the first conversion is already compared against the
//! right window, and the configuration write also sets Fault Status Clear
//! to drop faults latched before this boot (the chip keeps them across an
//! MCU reset).
//!
//! # Conversions
//!
//! * [`Mode::Auto`]: the chip converts continuously (VBIAS on);
//!   [`Max31865::read_code`] returns the latest result, a new one every
//!   ~16.7 ms (60 Hz) or ~20 ms (50 Hz).
//! * [`Mode::OneShot`]: VBIAS is off between conversions, which limits the
//!   element's self-heating. [`Max31865::read_one_shot`] does the whole
//!   sequence with a [`DelayNs`]: VBIAS on, wait [`BIAS_SETTLE_US`],
//!   1-Shot, wait [`conversion_time_us`], read, VBIAS off. A task that must
//!   not block uses [`Max31865::set_bias`], [`Max31865::start_conversion`]
//!   and [`Max31865::read_code`] with its own timer (or the chip's DRDY pin,
//!   which this driver does not handle). No other call waits.
//!
//! # Faults
//!
//! A set fault bit makes [`Max31865::read_code`] return
//! [`Error::Fault`] with the decoded status; faults stay latched until
//! [`Max31865::clear_fault`]. [`Max31865::run_fault_detection`] runs the
//! chip's automatic-delay fault-detection cycle (Configuration D3..D2 =
//! 01, byte `100X_010Xb`), which is valid when the input filter's time
//! constant is under 100 µs (the chip waits 100 µs before each check).
//!
//! # Example
//!
//! ```
//! # use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
//! use max31865::{Config, Filter, Max31865, Mode, RtdCode, Thresholds, Wires};
//! # let spi = Mock::new(&[
//! #     T::transaction_start(), T::write_vec(vec![0x83, 0xFF, 0xFE, 0x00, 0x00]), T::transaction_end(),
//! #     T::transaction_start(), T::write_vec(vec![0x80, 0xC3]), T::transaction_end(),
//! #     T::transaction_start(), T::write_vec(vec![0x00]), T::read_vec(vec![0xC1]), T::transaction_end(),
//! #     T::transaction_start(), T::write_vec(vec![0x03]), T::read_vec(vec![0xFF, 0xFE, 0x00, 0x00]), T::transaction_end(),
//! #     T::transaction_start(), T::write_vec(vec![0x01]), T::read_vec(vec![0x40, 0x00]), T::transaction_end(),
//! # ]);
//! let config = Config::new(Wires::Four, Filter::Hz50, Mode::Auto);
//! let mut rtd = Max31865::new(spi, config)?;
//! let code = rtd.read_code()?;
//! assert_eq!(code, RtdCode::new(8192).unwrap()); // 100 Ω with a 400 Ω reference
//! # let mut spi = rtd.release(); spi.done();
//! # Ok::<(), max31865::Error<embedded_hal::spi::ErrorKind>>(())
//! ```
#![no_std]

mod config;
mod error;
mod fault;
pub mod register;

pub use config::{
    conversion_time_us, Config, Filter, Mode, RtdCode, Thresholds, Wires, BIAS_SETTLE_US,
};
pub use error::Error;
pub use fault::FaultStatus;

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};
use register as reg;

/// Polling interval of [`Max31865::run_fault_detection`], in µs: the
/// automatic cycle inserts 100 µs delays before its checks, so checking
/// more often only costs bus time.
pub const FAULT_CYCLE_POLL_US: u32 = 100;
/// Polls before [`Max31865::run_fault_detection`] gives up with
/// [`Error::Timeout`]: 50 × 100 µs = 5 ms, several times the few 100 µs
/// steps of the automatic cycle.
pub const FAULT_CYCLE_MAX_POLLS: u32 = 50;

/// A MAX31865 on an SPI device (the device owns chip select).
#[derive(Debug)]
pub struct Max31865<SPI> {
    spi: SPI,
    config: Config,
    /// What the configuration register holds between operations (the
    /// resting byte: [`Config::register_byte`], plus VBIAS while it is
    /// switched on in one-shot mode). Kept so that no write needs a
    /// read-modify-write.
    cfg: u8,
}

impl<SPI: SpiDevice> Max31865<SPI> {
    /// Configures the chip and checks that it took the configuration.
    ///
    /// Writes the thresholds (83h..86h), then the configuration (80h, with
    /// Fault Status Clear), then reads both back ([`Self::verify_config`]).
    /// On error the SPI device is dropped: an `SpiDevice` is normally a
    /// cheap handle (e.g. an `embedded-hal-bus` device) that can be made
    /// again for a retry.
    pub fn new(spi: SPI, config: Config) -> Result<Self, Error<SPI::Error>> {
        let mut dev = Self {
            spi,
            config,
            cfg: config.register_byte(),
        };
        dev.configure(config)?;
        Ok(dev)
    }

    /// Writes a new configuration and verifies it, as [`Self::new`] does;
    /// also the way to recover a chip that [`Self::verify_config`] found
    /// reset.
    pub fn configure(&mut self, config: Config) -> Result<(), Error<SPI::Error>> {
        self.config = config;
        self.cfg = config.register_byte();
        let t = config.thresholds.register_bytes();
        self.spi.write(&[
            reg::HIGH_FAULT_THRESHOLD_MSB | reg::WRITE,
            t[0],
            t[1],
            t[2],
            t[3],
        ])?;
        self.write_config(self.cfg | reg::CFG_FAULT_CLEAR)?;
        self.verify_config()
    }

    /// Reads the configuration and threshold registers back and compares
    /// them with what the driver wrote.
    ///
    /// Compared bits: configuration D7, D6, D4, D3..D2 (must be 00) and D0
    /// ([`register::CFG_READBACK_MASK`]; D5 1-Shot and D1 Fault Status Clear
    /// self-clear); threshold MSBs in full and LSBs without the don't-care
    /// D0. The first difference is returned as [`Error::ConfigMismatch`].
    /// Do not call it during a fault-detection cycle (D3..D2 then read as
    /// non-zero).
    pub fn verify_config(&mut self) -> Result<(), Error<SPI::Error>> {
        let mut cfg = [0u8; 1];
        self.read_registers(reg::CONFIG, &mut cfg)?;
        check(reg::CONFIG, self.cfg, cfg[0], reg::CFG_READBACK_MASK)?;

        let wrote = self.config.thresholds.register_bytes();
        let mut read = [0u8; 4];
        self.read_registers(reg::HIGH_FAULT_THRESHOLD_MSB, &mut read)?;
        // MSB registers are compared in full, LSB registers without D0.
        const MASKS: [u8; 4] = [0xFF, 0xFE, 0xFF, 0xFE];
        for (i, ((w, r), m)) in wrote.iter().zip(read.iter()).zip(MASKS).enumerate() {
            // `i` < 4, so the address stays within 03h..06h.
            check(reg::HIGH_FAULT_THRESHOLD_MSB + i as u8, *w, *r, m)?;
        }
        Ok(())
    }

    /// The configuration in force.
    pub fn config(&self) -> Config {
        self.config
    }

    /// Reads the latest conversion result (RTD MSB and LSB, 01h..02h, in one
    /// frame).
    ///
    /// If the LSB's fault bit (D0) is set, reads the Fault Status register
    /// and returns [`Error::Fault`] with it instead of the code (whose
    /// status may be empty if the faults were cleared in between). Faults
    /// stay latched until [`Self::clear_fault`].
    ///
    /// In [`Mode::OneShot`], call it at least [`conversion_time_us`] after
    /// [`Self::start_conversion`]; earlier it returns the previous result.
    pub fn read_code(&mut self) -> Result<RtdCode, Error<SPI::Error>> {
        let mut buf = [0u8; 2];
        self.read_registers(reg::RTD_MSB, &mut buf)?;
        let word = u16::from_be_bytes(buf);
        if word & 1 != 0 {
            return Err(Error::Fault(self.read_fault_status()?));
        }
        Ok(RtdCode::from_register_word(word))
    }

    /// Reads the Fault Status register (07h) without clearing it.
    pub fn read_fault_status(&mut self) -> Result<FaultStatus, Error<SPI::Error>> {
        let mut buf = [0u8; 1];
        self.read_registers(reg::FAULT_STATUS, &mut buf)?;
        Ok(FaultStatus::from_bits(buf[0]))
    }

    /// Clears the latched faults: writes the configuration with Fault
    /// Status Clear (D1) set and D5, D3, D2 zero, as the datasheet
    /// requires; the other bits keep their values.
    pub fn clear_fault(&mut self) -> Result<(), Error<SPI::Error>> {
        self.write_config(self.cfg | reg::CFG_FAULT_CLEAR)
    }

    /// Switches VBIAS (Configuration D7) on or off in [`Mode::OneShot`].
    ///
    /// Switch it on [`BIAS_SETTLE_US`] (10.5 input time constants) before
    /// [`Self::start_conversion`], and off after the result has been read,
    /// to limit self-heating. In [`Mode::Auto`] VBIAS must stay on, so this
    /// returns [`Error::WrongMode`] without touching the bus.
    pub fn set_bias(&mut self, on: bool) -> Result<(), Error<SPI::Error>> {
        if self.config.mode == Mode::Auto {
            return Err(Error::WrongMode);
        }
        let cfg = if on {
            self.cfg | reg::CFG_VBIAS
        } else {
            self.cfg & !reg::CFG_VBIAS
        };
        self.write_config(cfg)?;
        self.cfg = cfg;
        Ok(())
    }

    /// Starts one conversion (Configuration D5 1-Shot, with D7 VBIAS) in
    /// [`Mode::OneShot`]; it begins when chip select rises at the end of
    /// the write. The result is ready [`conversion_time_us`] later.
    ///
    /// VBIAS is left on. If it was off, the input filter has not settled
    /// and the result is low: use [`Self::set_bias`] first, or
    /// [`Self::read_one_shot`]. In [`Mode::Auto`] this returns
    /// [`Error::WrongMode`] without touching the bus.
    pub fn start_conversion(&mut self) -> Result<(), Error<SPI::Error>> {
        if self.config.mode == Mode::Auto {
            return Err(Error::WrongMode);
        }
        self.cfg |= reg::CFG_VBIAS;
        self.write_config(self.cfg | reg::CFG_ONE_SHOT)
    }

    /// One complete blocking 1-shot measurement: VBIAS on, wait
    /// `bias_settle_us` (use [`BIAS_SETTLE_US`] unless the input filter is
    /// slower), start, wait the worst-case [`conversion_time_us`], read,
    /// VBIAS off. VBIAS is switched off even when the read fails; the read's
    /// error wins. About 77 ms at 50 Hz with the default settling time.
    pub fn read_one_shot<D: DelayNs>(
        &mut self,
        delay: &mut D,
        bias_settle_us: u32,
    ) -> Result<RtdCode, Error<SPI::Error>> {
        self.set_bias(true)?;
        delay.delay_us(bias_settle_us);
        self.start_conversion()?;
        delay.delay_us(conversion_time_us(self.config.filter, Mode::OneShot));
        let code = self.read_code();
        let off = self.set_bias(false);
        let code = code?;
        off?;
        Ok(code)
    }

    /// Starts the automatic-delay fault-detection cycle without waiting.
    ///
    /// First clears the latched faults (so the result reflects this cycle),
    /// then writes `100X_010Xb`: VBIAS on, Normally-Off conversion mode,
    /// D3..D2 = 01, keeping the 3-wire and filter bits. Finish with
    /// [`Self::poll_fault_detection`].
    pub fn start_fault_detection(&mut self) -> Result<(), Error<SPI::Error>> {
        self.clear_fault()?;
        let keep = self.cfg & (reg::CFG_THREE_WIRE | reg::CFG_FILTER_50HZ);
        self.write_config(reg::CFG_VBIAS | reg::CFG_FAULT_CYCLE_AUTO | keep)
    }

    /// Checks whether the fault-detection cycle has finished (D3..D2 read
    /// back as 00). If so, reads the Fault Status, restores the
    /// configuration (restarting auto conversions) and returns the status;
    /// `Ok(None)` while the cycle runs.
    pub fn poll_fault_detection(&mut self) -> Result<Option<FaultStatus>, Error<SPI::Error>> {
        let mut cfg = [0u8; 1];
        self.read_registers(reg::CONFIG, &mut cfg)?;
        if cfg[0] & reg::CFG_FAULT_CYCLE_MASK != 0 {
            return Ok(None);
        }
        let status = self.read_fault_status()?;
        self.write_config(self.cfg)?;
        Ok(Some(status))
    }

    /// Runs the automatic-delay fault-detection cycle to completion and
    /// returns the Fault Status it left (empty = no wiring fault found).
    ///
    /// Polls every [`FAULT_CYCLE_POLL_US`] µs, at most
    /// [`FAULT_CYCLE_MAX_POLLS`] times; then restores the configuration and
    /// returns [`Error::Timeout`]. The faults found stay latched in the chip
    /// (so the next [`Self::read_code`] reports them) until
    /// [`Self::clear_fault`].
    pub fn run_fault_detection<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<FaultStatus, Error<SPI::Error>> {
        self.start_fault_detection()?;
        for _ in 0..FAULT_CYCLE_MAX_POLLS {
            delay.delay_us(FAULT_CYCLE_POLL_US);
            if let Some(status) = self.poll_fault_detection()? {
                return Ok(status);
            }
        }
        self.write_config(self.cfg)?;
        Err(Error::Timeout)
    }

    /// Gives the SPI device back. The chip keeps running as configured.
    pub fn release(self) -> SPI {
        self.spi
    }

    fn write_config(&mut self, value: u8) -> Result<(), Error<SPI::Error>> {
        self.spi.write(&[reg::CONFIG | reg::WRITE, value])?;
        Ok(())
    }

    /// One frame: the read address, then `buf.len()` bytes from it on.
    fn read_registers(&mut self, address: u8, buf: &mut [u8]) -> Result<(), Error<SPI::Error>> {
        self.spi
            .transaction(&mut [Operation::Write(&[address]), Operation::Read(buf)])?;
        Ok(())
    }
}

/// `Ok` if `wrote` and `read` agree on the bits of `mask`.
fn check<E>(register: u8, wrote: u8, read: u8, mask: u8) -> Result<(), Error<E>> {
    if (wrote ^ read) & mask == 0 {
        Ok(())
    } else {
        Err(Error::ConfigMismatch {
            register,
            wrote,
            read,
        })
    }
}

#[cfg(test)]
mod tests;
