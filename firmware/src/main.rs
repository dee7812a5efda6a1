//! Sensor-hub firmware for thermal-error compensation of CNC machine tools.
//!
//! The hub reads RTD temperature sensors (MAX31865 converters on SPI1), runs
//! the thermal model and sends the resulting axis offsets to the CNC over CAN
//! (and a debug/host link on the ST-LINK virtual COM port). Target: STM32F446RE
//! on a NUCLEO-F446RE.
//!
//! # Architecture
//!
//! This binary is a thin shell, after quartiq/stabilizer: the RTIC app below
//! only wires peripherals together and schedules tasks. The measurement
//! pipeline (drivers generic over `embedded-hal`, sample -> model -> offset)
//! will live in hardware-independent, host-tested modules and crates
//! (`model-core`); this minimal version only has placeholders for it.
//!
//! * [`board`] and [`layout`]: plain constants (clocks, pinout, bus speeds,
//!   task periods, memory map) that build on both host and target.
//! * `app` (target only, `cfg(target_os = "none")`): the RTIC v2 application.
//!   `sample` (priority 2) runs every [`board::SAMPLE_PERIOD_MS`], probes the
//!   RTD converter, feeds the watchdog and hands its result to `emit`
//!   (priority 1), which reports over USART2 and CAN1 without delaying the
//!   next sample.
//! * Host build: `fn main` prints the memory layout, pinout and defaults, so
//!   CI (`cargo run -p firmware`) checks that they build and shows them.
//!
//! Board build: `cargo build -p firmware --target thumbv7em-none-eabihf --release`.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

// On the board some constants are only printed by the host build.
#[cfg_attr(target_os = "none", allow(dead_code))]
pub mod board;
#[cfg_attr(target_os = "none", allow(dead_code))]
pub mod layout;

/// Host build: print the memory layout, pinout and defaults.
#[cfg(not(target_os = "none"))]
fn main() {
    host::print_all();
}

#[cfg(not(target_os = "none"))]
mod host {
    use crate::{board, layout};

    /// Human-readable byte count.
    fn size(bytes: u32) -> String {
        if bytes % 1024 == 0 {
            format!("{} KiB", bytes / 1024)
        } else {
            format!("{bytes} B")
        }
    }

    pub fn print_all() {
        println!(
            "firmware {}: thermal-compensation sensor hub, STM32F446RE (NUCLEO-F446RE)",
            env!("CARGO_PKG_VERSION")
        );
        println!("(host build; board build: --target thumbv7em-none-eabihf)\n");

        println!("Memory layout (memory.x)");
        println!(
            "  {:<8} {:<11} {:<11} {:>8}  purpose",
            "region", "origin", "end", "size"
        );
        for r in layout::REGIONS {
            println!(
                "  {:<8} 0x{:08X}  0x{:08X}  {:>8}  {}",
                r.name,
                r.origin,
                r.end(),
                size(r.len),
                r.purpose
            );
        }
        println!("  linker symbols: _model_a_start/_model_a_end, _model_b_start/_model_b_end");
        let sectors: Vec<String> = (0..layout::FLASH_SECTOR_SIZES.len())
            .map(|n| format!("{n}@0x{:08X}", layout::sector_start(n)))
            .collect();
        println!("  flash sectors: {}\n", sectors.join(" "));

        println!("Pinout");
        println!("  {:<10} {:<5} {:<4} wired to", "signal", "pin", "AF");
        for p in board::PINOUT {
            let af = p.af.map_or_else(|| "-".to_string(), |af| format!("AF{af}"));
            println!("  {:<10} {:<5} {:<4} {}", p.signal, p.pin, af, p.note);
        }
        println!();

        let t = board::CAN_TIMING;
        let rows: [(&str, String); 11] = [
            ("HSE (bypass)", format!("{} MHz", board::HSE_HZ / 1_000_000)),
            ("SYSCLK", format!("{} MHz", board::SYSCLK_HZ / 1_000_000)),
            (
                "PCLK1 / PCLK2",
                format!("{} / {} MHz", board::PCLK1_HZ / 1_000_000, board::PCLK2_HZ / 1_000_000),
            ),
            ("sample period", format!("{} ms", board::SAMPLE_PERIOD_MS)),
            (
                "IWDG timeout",
                format!("{} ms (>= {} ms at fastest LSI)", board::IWDG_TIMEOUT_MS, board::IWDG_TIMEOUT_MIN_MS),
            ),
            ("USART2 baud", format!("{} 8N1", board::UART_BAUD)),
            ("CAN1 bitrate", format!("{} kbit/s", board::CAN_BITRATE / 1000)),
            (
                "CAN1 timing",
                format!(
                    "prescaler {}, {} tq (ts1 {}, ts2 {}, sjw {}), sample point {}.{}%, BTR 0x{:08X}",
                    t.prescaler,
                    t.quanta(),
                    t.ts1,
                    t.ts2,
                    t.sjw,
                    t.sample_point_permille() / 10,
                    t.sample_point_permille() % 10,
                    t.btr()
                ),
            ),
            ("CAN heartbeat id", format!("0x{:03X}", board::CAN_HEARTBEAT_ID)),
            ("RTD SPI1 clock", format!("<= {} kHz, mode {}", board::RTD_SPI_HZ / 1000, board::RTD_SPI_MODE)),
            ("monotonic tick", format!("{} Hz (SysTick)", board::MONO_HZ)),
        ];
        println!("Defaults");
        for (name, value) in rows {
            println!("  {name:<17} {value}");
        }
    }
}

/// Target-only runtime glue: logging transport, panic handler, monotonic
/// timer, the defmt timestamp and the model-slot linker symbols.
#[cfg(target_os = "none")]
mod rt {
    use defmt_rtt as _;
    use panic_probe as _;

    // The macro needs an untyped literal; `board` asserts MONO_HZ == 1_000.
    rtic_monotonics::systick_monotonic!(Mono, 1_000);

    // A tick is a millisecond (checked in `board`).
    defmt::timestamp!("{=u32:ms}", {
        use rtic_monotonics::Timebase;
        Mono::now().as_ticks()
    });

    extern "C" {
        // Defined in memory.x.
        static _model_a_start: u8;
        static _model_a_end: u8;
        static _model_b_start: u8;
        static _model_b_end: u8;
    }

    /// Model slot bounds `(a_start, a_end, b_start, b_end)` as the linker placed them.
    pub fn model_slots() -> [u32; 4] {
        [
            &raw const _model_a_start as u32,
            &raw const _model_a_end as u32,
            &raw const _model_b_start as u32,
            &raw const _model_b_end as u32,
        ]
    }
}

/// The RTIC v2 application (board only).
#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true, dispatchers = [UART4, UART5])]
mod app {
    use crate::{board, layout, rt::Mono};
    use bxcan::{Frame, StandardId};
    use rtic_monotonics::Timebase;
    use stm32f4xx_hal::{
        can::{Can, CanExt},
        gpio::{GpioExt, Output, PB6},
        hal::spi::MODE_1,
        hal_02::blocking::serial::Write as _,
        pac,
        prelude::_fugit_ExtU32,
        rcc::{Config, RccExt},
        serial::{Serial, SerialExt},
        spi::{Spi, SpiExt},
        time::{Bps, Hertz},
        watchdog::IndependentWatchdog,
    };

    /// CANopen heartbeat id of this node.
    const HEARTBEAT_ID: StandardId = match StandardId::new(board::CAN_HEARTBEAT_ID) {
        Some(id) => id,
        None => panic!("heartbeat id is not an 11-bit id"),
    };
    /// CANopen NMT state "operational" (CiA 301), the heartbeat payload.
    const NMT_OPERATIONAL: u8 = 0x05;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        watchdog: IndependentWatchdog,
        rtd_spi: Spi<pac::SPI1>,
        rtd_cs: PB6<Output>,
        uart: Serial<pac::USART2>,
        can: bxcan::Can<Can<pac::CAN1>>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;

        let mut rcc = dp.RCC.freeze(
            Config::hse(Hertz::from_raw(board::HSE_HZ))
                .bypass_hse_oscillator()
                .sysclk(Hertz::from_raw(board::SYSCLK_HZ))
                .pclk1(Hertz::from_raw(board::PCLK1_HZ))
                .pclk2(Hertz::from_raw(board::PCLK2_HZ)),
        );
        let clocks = rcc.clocks;
        defmt::assert_eq!(clocks.sysclk().raw(), board::SYSCLK_HZ);
        defmt::assert_eq!(clocks.pclk1().raw(), board::PCLK1_HZ);
        defmt::assert_eq!(clocks.pclk2().raw(), board::PCLK2_HZ);

        // SysTick counts the core clock (HCLK == SYSCLK here).
        Mono::start(cx.core.SYST, clocks.hclk().raw());

        // memory.x and `layout` must agree on where the model slots are.
        defmt::assert_eq!(
            crate::rt::model_slots(),
            [
                layout::MODEL_A.origin,
                layout::MODEL_A.end(),
                layout::MODEL_B.origin,
                layout::MODEL_B.end()
            ]
        );

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);

        let uart = dp
            .USART2
            .serial((gpioa.pa2, gpioa.pa3), Bps(board::UART_BAUD), &mut rcc)
            .unwrap();

        const _: () = assert!(board::RTD_SPI_MODE == 1);
        let rtd_spi = dp.SPI1.spi(
            (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
            MODE_1,
            Hertz::from_raw(board::RTD_SPI_HZ),
            &mut rcc,
        );
        let mut rtd_cs = gpiob.pb6.into_push_pull_output();
        rtd_cs.set_high();

        // `leave_disabled` instead of `enable`: `enable` blocks until it sees 11
        // recessive bits, which never happens without a transceiver. `emit`
        // finishes enabling without blocking.
        let can = bxcan::Can::builder(dp.CAN1.can((gpioa.pa12, gpioa.pa11), &mut rcc))
            .set_bit_timing(board::CAN_TIMING.btr())
            .leave_disabled();

        // Last: from here on `sample` must run at least every IWDG timeout.
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.stop_on_debug(&dp.DBGMCU, true);
        watchdog.start(board::IWDG_TIMEOUT_MS.millis());

        defmt::info!(
            "init: sysclk {=u32} Hz, pclk1 {=u32} Hz, sample period {=u32} ms",
            clocks.sysclk().raw(),
            clocks.pclk1().raw(),
            board::SAMPLE_PERIOD_MS
        );
        sample::spawn().ok();

        (
            Shared {},
            Local {
                watchdog,
                rtd_spi,
                rtd_cs,
                uart,
                can,
            },
        )
    }

    /// Periodic sampling (placeholder): probe the RTD converter's
    /// configuration register, feed the watchdog, pass the result to `emit`.
    #[task(priority = 2, local = [watchdog, rtd_spi, rtd_cs, seq: u32 = 0])]
    async fn sample(cx: sample::Context) {
        let period = <Mono as Timebase>::Duration::from_ticks(board::SAMPLE_PERIOD_MS);
        let mut next = Mono::now();
        loop {
            // MAX31865: read register 0x00 (configuration): address byte, then one dummy byte.
            let mut buf = [0x00u8, 0x00];
            cx.local.rtd_cs.set_low();
            let res = cx.local.rtd_spi.transfer_in_place(&mut buf);
            cx.local.rtd_cs.set_high();
            let config = match res {
                Ok(()) => Some(buf[1]),
                Err(_) => None,
            };

            *cx.local.seq = cx.local.seq.wrapping_add(1);
            defmt::info!("sample {=u32}: RTD config {=?}", *cx.local.seq, config);
            cx.local.watchdog.feed();

            if emit::spawn(*cx.local.seq).is_err() {
                defmt::warn!("emit still busy, sample {=u32} not reported", *cx.local.seq);
            }

            next += period;
            Mono::delay_until(next).await;
        }
    }

    /// Report one sample (placeholder): a text line on USART2 and a CANopen
    /// heartbeat on CAN1. Lower priority than `sample`, so a slow UART never
    /// delays sampling.
    #[task(priority = 1, local = [uart, can, can_up: bool = false])]
    async fn emit(cx: emit::Context, seq: u32) {
        let mut line = *b"hb 0000000000\r\n";
        write_decimal(&mut line[3..13], seq);
        if cx.local.uart.bwrite_all(&line).is_err() {
            defmt::warn!("USART2 write failed");
        }

        if !*cx.local.can_up {
            *cx.local.can_up = cx.local.can.enable_non_blocking().is_ok();
            if !*cx.local.can_up {
                defmt::debug!("CAN1 waiting for bus idle");
                return;
            }
            defmt::info!("CAN1 on bus");
        }
        let frame = Frame::new_data(HEARTBEAT_ID, [NMT_OPERATIONAL]);
        match cx.local.can.transmit(&frame) {
            Ok(_) => {}
            Err(_) => defmt::warn!("CAN1 mailboxes full, heartbeat dropped"),
        }
    }

    /// Right-aligned, zero-padded decimal of `value` into `out` (no `core::fmt`).
    fn write_decimal(out: &mut [u8], mut value: u32) {
        for digit in out.iter_mut().rev() {
            *digit = b'0' + (value % 10) as u8;
            value /= 10;
        }
    }
}
