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
//! only wires peripherals together and schedules tasks. Everything that can
//! be is hardware-independent and host-tested: the `firmware` library
//! (`lib.rs`: `board`, `layout`, `hub`) and `model-core`.
//!
//! * `app` (target only, `cfg(target_os = "none")`): the RTIC v2 application.
//!   `init` reads model slot A through `FlashExt::read` and loads it into a
//!   `hub::Hub`. `sample` (priority 2) runs every `board::SAMPLE_PERIOD_MS`,
//!   probes the RTD converter, steps the model, feeds the watchdog and hands
//!   its result to `emit` (priority 1), which reports over USART2 and CAN1
//!   without delaying the next sample.
//! * Host build: `fn main` prints the memory layout, pinout, defaults and the
//!   model slot facts, so CI (`cargo run -p firmware`) checks that they build
//!   and shows them.
//!
//! Board build: `cargo build -p firmware --target thumbv7em-none-eabihf --profile firmware`
//! (`--no-default-features`: the shell without the model path).
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

/// Host build: print the memory layout, pinout and defaults.
#[cfg(not(target_os = "none"))]
fn main() {
    host::print_all();
}

#[cfg(not(target_os = "none"))]
mod host {
    use firmware::{board, layout};

    /// Human-readable byte count.
    fn size(bytes: u32) -> String {
        if bytes.is_multiple_of(1024) {
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
        println!();

        print_model_slot();
    }

    /// What a model slot accepts and what a loaded model costs in RAM.
    #[cfg(feature = "model")]
    fn print_model_slot() {
        use firmware::hub::{Hub, MAX_INPUTS, MAX_OUTPUTS};
        use model_core::blob::{FORMAT_VERSION, MAX_BLOB_LEN};
        use model_core::{ModelState, ValidModel};
        use std::mem::size_of;

        let bytes = |n: usize| format!("{n} B ({:.1} KiB)", n as f64 / 1024.0);
        println!("Model slot (read at boot from MODEL_A)");
        println!(
            "  {:<19} {FORMAT_VERSION} (magic \"TCMB\")",
            "blob format version"
        );
        println!(
            "  {:<19} {MAX_BLOB_LEN} B (slot {})",
            "largest blob",
            size(layout::MODEL_A.len)
        );
        println!(
            "  {:<19} {MAX_INPUTS} inputs, {MAX_OUTPUTS} outputs",
            "capacity"
        );
        println!("  {:<19} {}", "ValidModel", bytes(size_of::<ValidModel>()));
        println!("  {:<19} {}", "ModelState", bytes(size_of::<ModelState>()));
        println!(
            "  {:<19} {} (static RAM of a loaded model)",
            "Hub",
            bytes(size_of::<Hub>())
        );
    }

    #[cfg(not(feature = "model"))]
    fn print_model_slot() {
        println!("Model slot: not built in (feature `model` off): offsets are always zero");
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
    use crate::rt::Mono;
    use bxcan::{Frame, StandardId};
    use core::mem::MaybeUninit;
    use firmware::{board, hub, layout};
    use rtic_monotonics::Timebase;
    use stm32f4xx_hal::{
        can::{Can, CanExt},
        flash::FlashExt,
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
        hub: &'static mut hub::Hub,
    }

    // `hub_slot` is a static that starts uninitialised (so it costs .bss, not
    // flash); `MaybeUninit::write` fills it safely and hands out the
    // `&'static mut` that `sample` keeps.
    #[init(local = [hub_slot: MaybeUninit<hub::Hub> = MaybeUninit::uninit()])]
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

        // The model: slot A as a byte slice of the memory-mapped flash (no
        // `unsafe` here: the HAL's `FlashExt::read`). A flash smaller than the
        // layout expects gives an empty slot, which loads as "no model".
        let flash = dp.FLASH;
        let start = (layout::MODEL_A.origin - layout::FLASH_BASE) as usize;
        let slot = flash
            .read()
            .get(start..start + layout::MODEL_A.len as usize)
            .unwrap_or(&[]);
        let hub = cx.local.hub_slot.write(hub::Hub::load(slot));
        log_model(hub);

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
                hub,
            },
        )
    }

    /// Boot log of the model slot: what was loaded, or why nothing was.
    #[cfg(feature = "model")]
    fn log_model(hub: &hub::Hub) {
        match (hub.model(), hub.load_error()) {
            (Some(model), _) => {
                let mut names = [""; hub::MAX_OUTPUTS];
                for (dst, name) in names.iter_mut().zip(model.outputs()) {
                    *dst = name.as_str();
                }
                defmt::info!(
                    "model {=str}: {=usize} inputs -> {=[?]}",
                    model.kind().name(),
                    model.inputs().len(),
                    names.get(..model.outputs().len()).unwrap_or(&[])
                );
            }
            (None, Some(error)) => defmt::warn!("no model: {}", error),
            (None, None) => defmt::warn!("no model"),
        }
    }

    #[cfg(not(feature = "model"))]
    fn log_model(_hub: &hub::Hub) {
        defmt::info!("model support not built in: offsets stay zero");
    }

    /// Log a refused sample once when the hub starts holding its offsets.
    #[cfg(feature = "model")]
    fn log_fault(hub: &hub::Hub, offsets: &hub::Offsets) {
        let faults = hub.faults();
        if faults.consecutive == 1 {
            if let Some(fault) = hub.last_fault() {
                defmt::warn!(
                    "model refused sample ({}): holding last good offsets {=[?]}",
                    fault,
                    offsets.values.get(..hub.output_count()).unwrap_or(&[])
                );
            }
        }
    }

    #[cfg(not(feature = "model"))]
    fn log_fault(_hub: &hub::Hub, _offsets: &hub::Offsets) {}

    /// Periodic sampling: probe the RTD converter's configuration register,
    /// step the model, feed the watchdog, pass the sequence number to `emit`.
    #[task(priority = 2, local = [watchdog, rtd_spi, rtd_cs, hub, seq: u32 = 0])]
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

            // No RTD driver yet: every channel reads as missing (NaN), so the
            // model refuses each sample and the hub holds its last good
            // offsets (zero) and counts the fault.
            let readings = [f64::NAN; hub::MAX_INPUTS];
            let hub = &mut **cx.local.hub;
            let inputs = readings.get(..hub.input_count()).unwrap_or(&[]);
            let offsets = hub.on_sample(inputs);
            log_fault(hub, &offsets);

            *cx.local.seq = cx.local.seq.wrapping_add(1);
            defmt::info!(
                "sample {=u32}: RTD config {=?}, offsets {=[?]} ({=str})",
                *cx.local.seq,
                config,
                offsets.values,
                if offsets.fresh { "fresh" } else { "held" }
            );
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
