//! Board facts for the NUCLEO-F446RE sensor hub: clocks, pinout, bus speeds
//! and task periods.
//!
//! Plain constants with no HAL types, so the host build can print them and the
//! board build can use them; each one says where its value comes from.
//! References: UM1724 (STM32 Nucleo-64 user manual), DS10693 (STM32F446xC/E
//! datasheet), RM0390 (STM32F446 reference manual), MAX31865 datasheet.

/// HSE input: the ST-LINK's MCO output, 8 MHz, wired to PH0/OSC_IN, so the
/// oscillator runs in bypass mode (UM1724, "OSC clock supply": MCO from ST-LINK).
pub const HSE_HZ: u32 = 8_000_000;

/// Core clock: the F446's maximum, which needs the regulator over-drive
/// (DS10693, "Regulator over-drive"); stm32f4xx-hal 0.23 enables over-drive itself above
/// 168 MHz. PLL: 8 MHz / M=4 * N=180 / P=2, exact.
pub const SYSCLK_HZ: u32 = 180_000_000;

/// APB1 clock (USART2, CAN1, IWDG bus): its 45 MHz maximum (DS10693, general operating conditions).
pub const PCLK1_HZ: u32 = 45_000_000;

/// APB2 clock (SPI1): its 90 MHz maximum (DS10693, general operating conditions).
pub const PCLK2_HZ: u32 = 90_000_000;

/// USART2 baud rate: 115200 8N1, what terminal programs expect on the
/// ST-LINK virtual COM port (USART2 is wired to the ST-LINK, UM1724 "USART communication").
pub const UART_BAUD: u32 = 115_200;

/// Requested SPI1 clock for the MAX31865 RTD converters (chip maximum 5 MHz,
/// MAX31865 datasheet "SCLK frequency"). 1 MHz leaves margin for wiring to
/// converters off the board; the HAL rounds down to a prescaler of PCLK2.
pub const RTD_SPI_HZ: u32 = 1_000_000;

/// SPI mode for the MAX31865: it accepts CPHA = 1 with either clock polarity
/// (modes 1 and 3, MAX31865 datasheet "Serial interface"); we use mode 1.
pub const RTD_SPI_MODE: u8 = 1;

/// CAN1 bit rate: 500 kbit/s, a common machine-tool/CANopen rate that allows
/// ~100 m of bus (CiA 301 bit-timing table).
pub const CAN_BITRATE: u32 = 500_000;

/// Bit timing for a bxCAN on APB1 (RM0390, bxCAN "Bit timing" and `CAN_BTR`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CanBitTiming {
    /// Baud-rate prescaler (1..=1024): one time quantum is `prescaler / PCLK1`.
    pub prescaler: u32,
    /// Time segment 1 in quanta (1..=16), propagation + phase 1.
    pub ts1: u32,
    /// Time segment 2 in quanta (1..=8), phase 2.
    pub ts2: u32,
    /// Resynchronisation jump width in quanta (1..=4).
    pub sjw: u32,
}

impl CanBitTiming {
    /// Quanta per bit: sync segment + TS1 + TS2.
    pub const fn quanta(&self) -> u32 {
        1 + self.ts1 + self.ts2
    }

    /// Resulting bit rate for a given APB1 clock.
    pub const fn bitrate(&self, pclk1_hz: u32) -> u32 {
        pclk1_hz / (self.prescaler * self.quanta())
    }

    /// Sample point in per mille of the bit, rounded.
    pub const fn sample_point_permille(&self) -> u32 {
        ((1 + self.ts1) * 1000 + self.quanta() / 2) / self.quanta()
    }

    /// The `CAN_BTR` register value (fields are stored minus one).
    pub const fn btr(&self) -> u32 {
        ((self.sjw - 1) << 24)
            | ((self.ts2 - 1) << 20)
            | ((self.ts1 - 1) << 16)
            | (self.prescaler - 1)
    }
}

/// 45 MHz / 6 = 7.5 MHz quanta, 15 quanta per bit = 500 kbit/s, sample point
/// 13/15 = 86.7 % (CiA 301 recommends 87.5 %; 45 MHz allows 86.7 or 88.9).
pub const CAN_TIMING: CanBitTiming = CanBitTiming {
    prescaler: 6,
    ts1: 12,
    ts2: 2,
    sjw: 1,
};

/// CAN node id of the hub (placeholder until the CAN protocol is frozen).
pub const CAN_NODE_ID: u16 = 0x01;

/// Heartbeat frame id: CANopen convention 0x700 + node id (CiA 301 NMT
/// error control), so bus tools recognise it.
pub const CAN_HEARTBEAT_ID: u16 = 0x700 + CAN_NODE_ID;

/// Sampling period. Machine-tool thermal time constants are minutes to hours,
/// so 1 Hz oversamples them many times; a MAX31865 conversion takes ~55 ms
/// (datasheet, 60 Hz filter), far inside the period.
pub const SAMPLE_PERIOD_MS: u32 = 1_000;

/// RTIC monotonic (SysTick) tick rate: 1 kHz, so a tick is a millisecond.
pub const MONO_HZ: u32 = 1_000;

/// Worst-case erase time of one 128 KiB flash sector as the firmware erases
/// it, ms. DS10693 "Flash memory programming" gives t_ERASE128KB typ 1 s /
/// max 2 s at x32 parallelism but typ 2 s / max 4 s at x8, and
/// stm32f4xx-hal 0.23's `UnlockedFlash::erase` always erases at x8
/// (`PSIZE = x8`); the CPU stalls for all of it (one flash bank).
pub const FLASH_SECTOR_ERASE_MAX_MS: u32 = 4_000;

/// Independent-watchdog timeout. The IWDG runs from the LSI, 17..47 kHz
/// (32 kHz typical; DS10693 "LSI oscillator characteristics"); the HAL
/// assumes 32 kHz, so the real timeout can be as short as 32/47 of this.
/// A model upload erases one 128 KiB sector, stalling the CPU for up to
/// [`FLASH_SECTOR_ERASE_MAX_MS`] (x8 erase); the upload feeds the watchdog
/// right before, and the sampling task feeds it at least every
/// [`SAMPLE_PERIOD_MS`]. 8 s keeps the fastest-LSI timeout (5.45 s) above
/// the 4 s erase plus one feed period (5 s). The price: with the slowest
/// LSI (17 kHz) a hung firmware is reset only after ~15 s.
pub const IWDG_TIMEOUT_MS: u32 = 8_000;

/// Worst-case (fastest LSI) watchdog timeout in ms.
pub const IWDG_TIMEOUT_MIN_MS: u32 = IWDG_TIMEOUT_MS * 32 / 47;

/// MAX31865 converters on SPI1, one chip select each ([`RTD_CS_PINS`]).
///
/// # Which model input reads which channel
///
/// A model input named `T<k>` (`T1`, `T2`, ... no leading zero) is read
/// from RTD channel `k`, i.e. the chip on the `k`-th entry of
/// [`RTD_CS_PINS`] ([`rtd_channel`] gives the 0-based index). The tool
/// length input (`tool_mm`) comes from the CNC's TOOL_POSITION frame or the
/// `SetToolLength` command; `speed_rpm`, `power_kw` and a positional
/// output's position from the CNC's frames (`can_rx`, `cnc_inputs`). Any
/// other input, or `T<k>` with `k` beyond [`RTD_CHANNELS`], has no source
/// and reads as stale every sample (so such a model holds its offsets).
pub const RTD_CHANNELS: usize = 8;

/// Chip-select pins of RTD channels 1..=[`RTD_CHANNELS`], in channel order
/// (active low, push-pull, idle high). The Arduino D10..D2 header pins in
/// order, skipping D3 (PB3, the SWO trace pin); PB4 (D5) is NJTRST after
/// reset, unused with SWD. Details in [`PINOUT`].
pub const RTD_CS_PINS: [&str; RTD_CHANNELS] =
    ["PB6", "PC7", "PA9", "PA8", "PB10", "PB4", "PB5", "PA10"];

/// The 0-based RTD channel a model input named `name` is read from:
/// `T<k>` -> `k - 1` for `k` in `1..=RTD_CHANNELS` (see [`RTD_CHANNELS`]).
pub fn rtd_channel(name: &str) -> Option<usize> {
    let digits = name.strip_prefix('T')?;
    if digits.is_empty() || digits.starts_with('0') || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let k: usize = digits.parse().ok()?;
    (1..=RTD_CHANNELS).contains(&k).then(|| k - 1)
}

/// Mains frequency the MAX31865 notch filter rejects: 50 Hz (Europe, most
/// of Asia and Africa). Conversions then take 21 ms instead of 17.6 ms,
/// irrelevant at one sample per second; a 60 Hz site (Americas, parts of
/// Japan) sets 60 here, else mains pickup on long sensor leads is only
/// partly rejected.
pub const RTD_MAINS_HZ: u32 = 50;

/// RTD wiring the converters are configured for: 3-wire, the usual
/// industrial PT100 connection (the chip cancels the lead resistance).
/// Must match the converter boards' jumpers; 2- and 4-wire sensors use 2 or 4.
pub const RTD_WIRES: u8 = 3;

/// While a converter is down (failed configuration) it is retried this
/// often, ms; the configured ones have their configuration read back at the
/// same rate (a brown-out resets a chip to "no conversions" silently).
pub const RTD_RETRY_MS: u32 = 10_000;

/// How long a value received from the CNC (spindle speed, power, axis
/// position; `cnc_inputs`) stays valid, ms. A CNC or PLC sends them every
/// 100 ms to 1 s; 5 s rides out a few lost frames or a PLC cycle stall
/// (5 samples at 1 Hz), while a stopped sender is flagged within seconds,
/// long before the thermal error moves (drift < 0.1 um/s, `limiter`).
/// The tool length does not time out (it is sent on tool changes only).
pub const CNC_INPUT_TIMEOUT_MS: u32 = 5_000;

/// The slowest period at which the CNC may send its cyclic inputs, ms
/// (docs/cnc-integration.md, "What the CNC must send").
pub const CNC_FRAME_PERIOD_MAX_MS: u32 = 1_000;

/// The shortest CNC input timeout a user may set (CANopen 0x2007): two of
/// the slowest frame periods, so that one late or lost frame of a CNC
/// sending at the documented rate never reads as a stopped sender (a
/// shorter timeout would flag such a CNC stale between its frames, and at
/// one sample per second it would not detect a real stop any sooner).
pub const CNC_INPUT_TIMEOUT_MIN_MS: u32 = 2 * CNC_FRAME_PERIOD_MAX_MS;

/// One MCU pin and what it is wired to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinAssignment {
    /// Peripheral signal.
    pub signal: &'static str,
    /// MCU pin.
    pub pin: &'static str,
    /// Alternate function number, `None` for plain GPIO/analog.
    pub af: Option<u8>,
    /// Where the pin goes on the NUCLEO-F446RE.
    pub note: &'static str,
}

/// Pinout (alternate functions: DS10693 "Alternate function mapping"; NUCLEO wiring: UM1724).
pub const PINOUT: [PinAssignment; 8 + RTD_CHANNELS] = [
    PinAssignment {
        signal: "HSE_IN",
        pin: "PH0",
        af: None,
        note: "8 MHz MCO from ST-LINK (bypass)",
    },
    PinAssignment {
        signal: "USART2_TX",
        pin: "PA2",
        af: Some(7),
        note: "ST-LINK virtual COM port",
    },
    PinAssignment {
        signal: "USART2_RX",
        pin: "PA3",
        af: Some(7),
        note: "ST-LINK virtual COM port",
    },
    PinAssignment {
        signal: "SPI1_SCK",
        pin: "PA5",
        af: Some(5),
        note: "MAX31865 SCLK; also LED LD2 (D13)",
    },
    PinAssignment {
        signal: "SPI1_MISO",
        pin: "PA6",
        af: Some(5),
        note: "MAX31865 SDO (D12)",
    },
    PinAssignment {
        signal: "SPI1_MOSI",
        pin: "PA7",
        af: Some(5),
        note: "MAX31865 SDI (D11)",
    },
    PinAssignment {
        signal: "RTD1_CS",
        pin: "PB6",
        af: None,
        note: "MAX31865 #1 /CS, input T1 (D10)",
    },
    PinAssignment {
        signal: "RTD2_CS",
        pin: "PC7",
        af: None,
        note: "MAX31865 #2 /CS, input T2 (D9)",
    },
    PinAssignment {
        signal: "RTD3_CS",
        pin: "PA9",
        af: None,
        note: "MAX31865 #3 /CS, input T3 (D8)",
    },
    PinAssignment {
        signal: "RTD4_CS",
        pin: "PA8",
        af: None,
        note: "MAX31865 #4 /CS, input T4 (D7)",
    },
    PinAssignment {
        signal: "RTD5_CS",
        pin: "PB10",
        af: None,
        note: "MAX31865 #5 /CS, input T5 (D6)",
    },
    PinAssignment {
        signal: "RTD6_CS",
        pin: "PB4",
        af: None,
        note: "MAX31865 #6 /CS, input T6 (D5, NJTRST after reset)",
    },
    PinAssignment {
        signal: "RTD7_CS",
        pin: "PB5",
        af: None,
        note: "MAX31865 #7 /CS, input T7 (D4)",
    },
    PinAssignment {
        signal: "RTD8_CS",
        pin: "PA10",
        af: None,
        note: "MAX31865 #8 /CS, input T8 (D2)",
    },
    PinAssignment {
        signal: "CAN1_RX",
        pin: "PA11",
        af: Some(9),
        note: "to transceiver RXD (CN10-14)",
    },
    PinAssignment {
        signal: "CAN1_TX",
        pin: "PA12",
        af: Some(9),
        note: "to transceiver TXD (CN10-12)",
    },
];

// Compile-time checks on the design constants.
const _: () = {
    assert!(CAN_TIMING.bitrate(PCLK1_HZ) == CAN_BITRATE);
    assert!(PCLK1_HZ.is_multiple_of(CAN_TIMING.prescaler * CAN_TIMING.quanta()));
    assert!(CAN_TIMING.ts1 >= 1 && CAN_TIMING.ts1 <= 16);
    assert!(CAN_TIMING.ts2 >= 1 && CAN_TIMING.ts2 <= 8);
    assert!(CAN_TIMING.sjw >= 1 && CAN_TIMING.sjw <= 4 && CAN_TIMING.sjw <= CAN_TIMING.ts2);
    assert!(CAN_TIMING.prescaler >= 1 && CAN_TIMING.prescaler <= 1024);
    assert!(SYSCLK_HZ == HSE_HZ / 4 * 180 / 2);
    assert!(SYSCLK_HZ.is_multiple_of(MONO_HZ) && MONO_HZ == 1_000);
    // The watchdog must survive one feed period plus 25 % jitter even with the fastest LSI.
    assert!(IWDG_TIMEOUT_MIN_MS > SAMPLE_PERIOD_MS + SAMPLE_PERIOD_MS / 4);
    // ... and a sector erase (CPU stalled) right after a feed, plus one feed period.
    assert!(IWDG_TIMEOUT_MIN_MS > FLASH_SECTOR_ERASE_MAX_MS + SAMPLE_PERIOD_MS);
    assert!(RTD_MAINS_HZ == 50 || RTD_MAINS_HZ == 60);
    assert!(RTD_WIRES >= 2 && RTD_WIRES <= 4);
    assert!(RTD_RETRY_MS >= SAMPLE_PERIOD_MS);
    // A CNC value must survive at least one sample period.
    assert!(CNC_INPUT_TIMEOUT_MS >= SAMPLE_PERIOD_MS);
    assert!(CNC_INPUT_TIMEOUT_MS >= CNC_INPUT_TIMEOUT_MIN_MS);
    assert!(IWDG_TIMEOUT_MS < 32_768); // HAL limit
    assert!(CAN_HEARTBEAT_ID <= 0x7FF); // 11-bit standard id
    assert!(RTD_SPI_HZ <= 5_000_000);
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_names_map_to_rtd_channels() {
        assert_eq!(rtd_channel("T1"), Some(0));
        assert_eq!(rtd_channel("T8"), Some(7));
        for name in [
            "T0",
            "T9",
            "T01",
            "T",
            "t1",
            "T1a",
            "tool_mm",
            "T+1",
            "",
            "T99999999999999999999",
        ] {
            assert_eq!(rtd_channel(name), None, "{name}");
        }
    }

    #[test]
    fn every_rtd_cs_pin_is_in_the_pinout_once() {
        for (k, pin) in RTD_CS_PINS.iter().enumerate() {
            let rows: Vec<_> = PINOUT.iter().filter(|p| p.pin == *pin).collect();
            assert_eq!(rows.len(), 1, "{pin}");
            assert_eq!(rows[0].signal, format!("RTD{}_CS", k + 1));
        }
        let mut pins: Vec<_> = PINOUT.iter().map(|p| p.pin).collect();
        pins.sort_unstable();
        pins.dedup();
        assert_eq!(pins.len(), PINOUT.len(), "a pin used twice");
    }
}
