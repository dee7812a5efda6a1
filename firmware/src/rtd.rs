//! One MAX31865 RTD converter as the sampling task sees it: configured or
//! down, read into a [`Reading`] once per sample, retried while down.
//!
//! Generic over [`SpiDevice`] so the whole path (driver error -> channel
//! fault, fault clearing, retry) runs against `embedded-hal-mock` on the host;
//! on the board the device is an `embedded-hal-bus` device on the shared SPI1.
//!
//! # Driver errors -> channel faults ([`fault_of`])
//!
//! | driver error | channel fault | why |
//! |---|---|---|
//! | `Error::Spi` | [`ChannelFault::Bus`] | the transfer itself failed |
//! | `Error::ConfigMismatch` | [`ChannelFault::Bus`] | chip missing, MISO stuck, or chip reset |
//! | `Fault`, D7 RTD high threshold | [`ChannelFault::Open`] | full-range window: only the top code (open element) trips it |
//! | `Fault`, D5 REFIN- > 0.85 VBIAS | [`ChannelFault::Open`] | open RTD or FORCE+ open (datasheet Tables 10-12) |
//! | `Fault`, D4/D3 "< 0.85 VBIAS (FORCE- open)" | [`ChannelFault::Open`] | FORCE- open per the bit names |
//! | `Fault`, D6 RTD low threshold | [`ChannelFault::Short`] | only code 0 (shorted element) trips it |
//! | `Fault`, D2 over/undervoltage, or no bit | [`ChannelFault::Converter`] | an input beyond the rails, or a fault cleared in between |
//! | `WrongMode`, `Timeout`, other | [`ChannelFault::Converter`] | not expected in auto mode |
//!
//! Open wins over short when both are latched (an open lead is the more
//! common wiring fault and the sharper warning). After a fault the latch is
//! cleared ([`Max31865::clear_fault`]) so the next sample shows whether it
//! persists.

use embedded_hal::spi::SpiDevice;
use max31865::{Config, Error, FaultStatus, Max31865};

use crate::board;
use crate::offsets::MAX_INPUTS;
use crate::pipeline::{ChannelFault, Reading};

/// One sample's readings in the model's input order: an input named
/// `T<k>` is read from RTD channel `k - 1` ([`board::rtd_channel`]) by
/// `read(channel)`; any other input (speed, power, a position, the tool
/// length) from `other(input index, name)` (on the board:
/// `cnc_inputs::gather`, the values received from the CNC). Also the
/// temperatures read, for telemetry (NaN where there is none).
pub fn gather<'a>(
    input_names: impl IntoIterator<Item = &'a str>,
    mut read: impl FnMut(usize) -> Reading,
    mut other: impl FnMut(usize, &str) -> Reading,
) -> ([Reading; MAX_INPUTS], [f64; MAX_INPUTS]) {
    let mut readings = [Reading::Stale; MAX_INPUTS];
    let mut temps_c = [f64::NAN; MAX_INPUTS];
    for (j, ((r, t), name)) in readings
        .iter_mut()
        .zip(&mut temps_c)
        .zip(input_names)
        .enumerate()
    {
        if let Some(k) = board::rtd_channel(name) {
            *r = read(k);
            if let Reading::Value(v) = *r {
                *t = v;
            }
        } else {
            *r = other(j, name);
        }
    }
    (readings, temps_c)
}

/// The channel fault a driver error means (table in the module docs).
pub fn fault_of<E>(error: &Error<E>) -> ChannelFault {
    match error {
        Error::Spi(_) | Error::ConfigMismatch { .. } => ChannelFault::Bus,
        Error::Fault(status) => fault_of_status(*status),
        _ => ChannelFault::Converter,
    }
}

/// The channel fault a Fault Status register value means.
pub fn fault_of_status(status: FaultStatus) -> ChannelFault {
    const OPEN: u8 = FaultStatus::RTD_HIGH_THRESHOLD
        | FaultStatus::REFIN_HIGH
        | FaultStatus::REFIN_LOW_FORCE_OPEN
        | FaultStatus::RTDIN_LOW_FORCE_OPEN;
    if status.bits() & OPEN != 0 {
        ChannelFault::Open
    } else if status.rtd_low_threshold() {
        ChannelFault::Short
    } else {
        ChannelFault::Converter
    }
}

/// One converter channel: `Up` after a successful configuration, else down.
#[derive(Debug)]
pub struct Converter<D> {
    chip: Option<Max31865<D>>,
}

impl<D> Default for Converter<D> {
    fn default() -> Self {
        Self::down()
    }
}

impl<D> Converter<D> {
    /// A channel not (yet) configured: reads as [`ChannelFault::Bus`].
    pub const fn down() -> Self {
        Self { chip: None }
    }

    /// Whether the chip is configured.
    pub fn is_up(&self) -> bool {
        self.chip.is_some()
    }
}

impl<D: SpiDevice> Converter<D> {
    /// Configures the chip on `device` (thresholds, configuration, read-back:
    /// [`Max31865::new`]). On failure the channel stays down and `device`
    /// is dropped; call again with a new device handle to retry.
    pub fn start(&mut self, device: D, config: Config) -> Result<(), ChannelFault> {
        match Max31865::new(device, config) {
            Ok(chip) => {
                self.chip = Some(chip);
                Ok(())
            }
            Err(e) => {
                self.chip = None;
                Err(fault_of(&e))
            }
        }
    }

    /// The latest conversion as a PT100 temperature ([`Reading::pt100`]),
    /// or the fault. A latched converter fault is cleared after it was
    /// read (if clearing fails the latch reports again next sample). A
    /// down channel reads [`ChannelFault::Bus`] without touching the bus.
    pub fn read(&mut self) -> Reading {
        let Some(chip) = self.chip.as_mut() else {
            return Reading::Fault(ChannelFault::Bus);
        };
        match chip.read_code() {
            Ok(code) => Reading::pt100(code.value()),
            Err(e) => {
                if matches!(e, Error::Fault(_)) {
                    let _ = chip.clear_fault();
                }
                Reading::Fault(fault_of(&e))
            }
        }
    }

    /// Reads the configuration back ([`Max31865::verify_config`]); a chip
    /// that no longer holds it (brown-out reset, unplugged) goes down, to be
    /// restarted by [`Converter::start`].
    pub fn check(&mut self) -> Result<(), ChannelFault> {
        let Some(chip) = self.chip.as_mut() else {
            return Err(ChannelFault::Bus);
        };
        chip.verify_config().map_err(|e| {
            self.chip = None;
            fault_of(&e)
        })
    }
}

#[cfg(test)]
mod tests {
    /// `T<k>` inputs are read from channel k - 1, in the model's input
    /// order; other names go to `other` with their index; faults pass through.
    #[test]
    fn gather_reads_rtd_inputs_by_name_in_model_order() {
        let mut asked = std::vec::Vec::new();
        let mut others = std::vec::Vec::new();
        let (r, t) = super::gather(
            ["T3", "speed_rpm", "T1", "T9"],
            |k| {
                asked.push(k);
                match k {
                    2 => Reading::Value(31.5),
                    0 => Reading::Fault(ChannelFault::Open),
                    _ => Reading::Stale,
                }
            },
            |j, name| {
                others.push((j, name.to_string()));
                Reading::Stale
            },
        );
        assert_eq!(others, [(1, "speed_rpm".into()), (3, "T9".into())]);
        assert_eq!(asked, [2, 0], "T9 is past the board's 8 channels");
        assert_eq!(r[0], Reading::Value(31.5));
        assert_eq!(r[1], Reading::Stale);
        assert_eq!(r[2], Reading::Fault(ChannelFault::Open));
        assert_eq!(r[3], Reading::Stale);
        assert_eq!(t[0], 31.5);
        assert!(t[1..].iter().all(|v| v.is_nan()));
    }

    use super::*;
    use embedded_hal::spi::ErrorKind;
    use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
    use max31865::{Filter, Mode, Wires};

    const CONFIG: Config = Config::new(Wires::Three, Filter::Hz50, Mode::Auto);
    /// Auto + VBIAS + 3-wire + 50 Hz.
    const CFG: u8 = 0xC0 | 0x10 | 0x01;

    fn frame(write: &[u8], read: Option<&[u8]>) -> Vec<T<u8>> {
        let mut v = vec![T::transaction_start(), T::write_vec(write.to_vec())];
        if let Some(r) = read {
            v.push(T::read_vec(r.to_vec()));
        }
        v.push(T::transaction_end());
        v
    }

    /// Bus traffic of a successful `Max31865::new` with `CONFIG`.
    fn init(read_cfg: u8) -> Vec<T<u8>> {
        [
            frame(&[0x83, 0xFF, 0xFE, 0x00, 0x00], None),
            frame(&[0x80, CFG | 0x02], None),
            frame(&[0x00], Some(&[read_cfg])),
            frame(&[0x03], Some(&[0xFF, 0xFE, 0x00, 0x00])),
        ]
        .concat()
    }

    #[test]
    fn fault_bits_map_as_documented() {
        let f = |bits| fault_of_status(FaultStatus::from_bits(bits));
        assert_eq!(f(0x80), ChannelFault::Open);
        assert_eq!(f(0xA0), ChannelFault::Open);
        assert_eq!(f(0x10), ChannelFault::Open);
        assert_eq!(f(0x08), ChannelFault::Open);
        assert_eq!(f(0x40), ChannelFault::Short);
        assert_eq!(f(0xC0), ChannelFault::Open, "open wins over short");
        assert_eq!(f(0x04), ChannelFault::Converter);
        assert_eq!(f(0x00), ChannelFault::Converter);
        assert_eq!(
            fault_of(&Error::<ErrorKind>::Spi(ErrorKind::Overrun)),
            ChannelFault::Bus
        );
        assert_eq!(
            fault_of(&Error::<ErrorKind>::ConfigMismatch {
                register: 0,
                wrote: CFG,
                read: 0
            }),
            ChannelFault::Bus
        );
        assert_eq!(
            fault_of(&Error::<ErrorKind>::Timeout),
            ChannelFault::Converter
        );
    }

    #[test]
    fn reads_temperature_then_fault_clears_the_latch() {
        let mut script = init(CFG);
        // 0 C: code 8192 = register word 0x4000.
        script.extend(frame(&[0x01], Some(&[0x40, 0x00])));
        // Fault bit set, status D7 (open), then the clear.
        script.extend(frame(&[0x01], Some(&[0xFF, 0xFF])));
        script.extend(frame(&[0x07], Some(&[0x80])));
        script.extend(frame(&[0x80, CFG | 0x02], None));
        let mut spi = Mock::new(&script);
        let mut ch = Converter::down();
        assert_eq!(ch.read(), Reading::Fault(ChannelFault::Bus));
        assert_eq!(ch.start(spi.clone(), CONFIG), Ok(()));
        assert!(ch.is_up());
        assert_eq!(ch.read(), Reading::Value(0.0));
        assert_eq!(ch.read(), Reading::Fault(ChannelFault::Open));
        spi.done();
    }

    #[test]
    fn missing_chip_stays_down_and_a_reset_chip_goes_down() {
        // MISO stuck low: the configuration reads back 0x00.
        let mut script = init(0x00);
        script.truncate(10); // up to and including the config read frame
                             // Retry succeeds; later the chip has reset (config 0x00).
        script.extend(init(CFG));
        script.extend(frame(&[0x00], Some(&[0x00])));
        let mut spi = Mock::new(&script);
        let mut ch = Converter::down();
        assert_eq!(ch.start(spi.clone(), CONFIG), Err(ChannelFault::Bus));
        assert!(!ch.is_up());
        assert_eq!(ch.start(spi.clone(), CONFIG), Ok(()));
        assert_eq!(ch.check(), Err(ChannelFault::Bus));
        assert!(!ch.is_up());
        assert_eq!(ch.read(), Reading::Fault(ChannelFault::Bus));
        spi.done();
    }
}
