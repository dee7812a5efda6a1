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
//!   `init` boots (`firmware::boot::boot` over both slots, read through
//!   `FlashExt::read`): a `Pipeline` without a model built in its static,
//!   the slots' blobs loaded into it there in the order their commit records
//!   give until one loads (`Pipeline::load`: the model never passes through
//!   the stack, docs/firmware-cost.md "Stack"; the slot booted is
//!   `upload::select_boot_slot`'s), and sets up USART2, SPI1 with one chip select per MAX31865
//!   (`board::RTD_CS_PINS`), CAN1 and the IWDG.
//!   - `sample` (priority 2): configures the converters (auto conversion),
//!     then every `Pipeline::sample_period_ms` from a fixed start reads the
//!     converter of each model input `T<k>` (`board::rtd_channel`), runs
//!     `Pipeline::on_sample`, feeds the watchdog and queues the result for
//!     `emit`; every `board::RTD_RETRY_MS` it restarts converters that are
//!     down and reads back the configuration of the others (`firmware::rtd`).
//!     The values the CNC sent over CAN (speed, power, axis position) are
//!     read through `cnc_inputs::gather` (stale after
//!     `board::CNC_INPUT_TIMEOUT_MS`); a tool length received since the
//!     last sample goes into the pipeline's tool-length latch first.
//!   - `emit` (priority 1): COBS telemetry on USART2; on CAN1 the CANopen
//!     node's boot-up (once the bus is up), its EMCYs, TPDOs (the frames of
//!     `can_frames`) and heartbeat (`canopen::Node`).
//!   - `can_rx` (interrupt CAN1_RX0, priority 3): every frame for the node
//!     (CAN1's filter passes only NMT 0x000, SDO 0x600 + node, RPDO1/2)
//!     into `canopen::Node::on_frame`; SDO responses go straight out, the
//!     CNC's values are stored with their arrival time in a small shared
//!     `CncInputs`, NMT reset node resets the MCU.
//!   - `store` (priority 1): settings saved by SDO 0x1010 into the settings
//!     sector (`canopen::store`), through the uploader's flash.
//!   - `usart2` (interrupt, priority 3): bytes into a `protocol::FrameReader`,
//!     decoded commands through an `rtic_sync` channel to `command`.
//!   - `command` (priority 1): ping, tool length, and model uploads through
//!     `upload::Uploader` on the board flash; a committed model is swapped
//!     into the pipeline under the lock, between two samples.
//!
//!   Without the `model` feature the same tasks run, but `sample` reads no
//!   converters and reports `NoModel`, and only `Ping` is accepted.
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
    use firmware::{board, can_frames, can_rx, layout};

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
        println!(
            "  {:<17} {} ms max (x8, CPU stalled; IWDG must outlast it)",
            "sector erase",
            board::FLASH_SECTOR_ERASE_MAX_MS
        );
        println!();

        println!(
            "RTD channels (MAX31865 on SPI1, {}-wire, {} Hz filter, auto conversion; retry/check every {} ms)",
            board::RTD_WIRES,
            board::RTD_MAINS_HZ,
            board::RTD_RETRY_MS
        );
        println!("  model input T<k> reads channel k; speed_rpm, power_kw, tool_mm and a position come from the CNC (below); other inputs read stale");
        for (k, pin) in board::RTD_CS_PINS.iter().enumerate() {
            let input = format!("T{}", k + 1);
            debug_assert_eq!(board::rtd_channel(&input), Some(k));
            println!("  {input:<4} <- RTD{} /CS {pin}", k + 1);
        }
        println!();

        println!(
            "CAN frames (CAN 2.0A, node 0x{:02X}; spec docs/wire-format.md, thermcomp.dbc)",
            board::CAN_NODE_ID
        );
        let frames: [(&str, u16, &str); 5] = [
            (
                "OFFSETS",
                can_frames::OFFSETS_ID,
                "every sample: outputs 1-3, state, counter",
            ),
            (
                "STATUS",
                can_frames::STATUS_ID,
                "every sample: flags, faulty channels, shape",
            ),
            (
                "OFFSETS_EXT",
                can_frames::OFFSETS_EXT_ID,
                "every sample with a 4th output",
            ),
            (
                "SLOPE",
                can_frames::SLOPE_ID,
                "every sample, one per positional output",
            ),
            (
                "HEARTBEAT",
                can_frames::HEARTBEAT_ID,
                "NMT state, checked at every sample",
            ),
        ];
        for (name, id, when) in frames {
            println!("  0x{id:03X}  {name:<12} {when}");
        }
        println!(
            "  heartbeat period {} ms; offsets {} um/bit",
            can_frames::DEFAULT_HEARTBEAT_MS,
            can_frames::OFFSET_UM_PER_BIT
        );
        println!("  received from the CNC (CANopen RPDO1/RPDO2; raw 0x7FFF.. = not available):");
        println!(
            "  0x{:03X}  {:<14} speed_rpm i32 {} rpm/bit, power_kw i16 {} kW/bit",
            can_rx::SPINDLE_ID,
            "SPINDLE",
            can_rx::SPEED_RPM_PER_BIT,
            can_rx::POWER_KW_PER_BIT
        );
        println!(
            "  0x{:03X}  {:<14} tool_mm i32 {} mm/bit (latched), position i32 {} mm/bit",
            can_rx::TOOL_POSITION_ID,
            "TOOL_POSITION",
            can_rx::TOOL_MM_PER_BIT,
            can_rx::POSITION_MM_PER_BIT
        );
        println!(
            "  CNC input timeout {} ms: speed, power, position stale after it (hold, ramp); tool length never times out",
            board::CNC_INPUT_TIMEOUT_MS
        );
        println!(
            "  CANopen (CiA 301, firmware/thermcomp.eds): NMT 0x000, EMCY 0x{:03X}, SDO 0x{:03X}/0x{:03X}, boot-up/heartbeat 0x{:03X}; {} dictionary entries",
            0x80 + board::CAN_NODE_ID,
            0x600 + board::CAN_NODE_ID,
            0x580 + board::CAN_NODE_ID,
            0x700 + board::CAN_NODE_ID,
            firmware::canopen::od::LEN
        );
        println!();

        print_fault_handling();
        print_model_slot();
    }

    /// The pipeline's defaults: spike filter, fault supervisor, limits.
    #[cfg(feature = "model")]
    fn print_fault_handling() {
        let c = firmware::pipeline::PipelineConfig::DEFAULT;
        let (sup, lim, spike, plaus) = (c.supervisor, c.limiter, c.spike, c.plausible);
        println!("Fault handling and limits (pipeline::PipelineConfig::DEFAULT)");
        let rows = [
            (
                "spike filter",
                format!(
                "a jump beyond {} K/s x dt + {} K is a spike; a level lasting {} samples is real",
                spike.max_rate_k_per_s, spike.noise_k, spike.persist_samples
            ),
            ),
            (
                "plausible",
                format!(
                    "{}..={} C, else IMPLAUSIBLE (a sensor fault)",
                    plaus.min_c, plaus.max_c
                ),
            ),
            (
                "rate of change",
                format!(
                    "over {} K from the anchor within {} s ({} K/s) is RATE_OF_CHANGE",
                    plaus.max_rate_k_per_s * plaus.rate_window_s,
                    plaus.rate_window_s,
                    plaus.max_rate_k_per_s
                ),
            ),
            (
                "stuck",
                format!(
                    "one value for {} s while another temperature moved {} K is STUCK",
                    plaus.stuck_time_s, plaus.stuck_others_k
                ),
            ),
            (
                "hold",
                format!("{} s of last good offsets on a bad sample", sup.hold_time_s),
            ),
            (
                "ramp",
                format!("then to zero at {} um/s", sup.ramp_um_per_s),
            ),
            (
                "recover",
                format!(
                    "a failed input must read good {} s in a row (RECOVERING)",
                    sup.recover_time_s
                ),
            ),
            (
                "flapping",
                format!(
                    "{} separate faults within {} s fail an input (ramp, then recover)",
                    sup.flap_faults, sup.flap_window_s
                ),
            ),
            ("slew", format!("{:?} um/s per output", lim.slew_um_per_s)),
            ("clamp", format!("{:?} um per output", lim.clamp_um)),
            (
                "slope stroke",
                format!(
                    "{} mm: slope limits = offset limits / stroke",
                    c.slope_stroke_mm
                ),
            ),
        ];
        for (name, value) in rows {
            println!("  {name:<17} {value}");
        }
        println!();
    }

    #[cfg(not(feature = "model"))]
    fn print_fault_handling() {}

    /// What a model slot accepts and what a loaded model costs in RAM.
    #[cfg(feature = "model")]
    fn print_model_slot() {
        use firmware::hub::{Hub, MAX_INPUTS, MAX_OUTPUTS};
        use model_core::blob::{FORMAT_VERSION, MAX_BLOB_LEN, OLDEST_READ_VERSION};
        use model_core::{ModelState, ValidModel};
        use std::mem::size_of;

        let bytes = |n: usize| format!("{n} B ({:.1} KiB)", n as f64 / 1024.0);
        println!("Model slots (boot: the committed slot with the highest generation, upload::select_boot_slot)");
        println!(
            "  {:<19} {FORMAT_VERSION} (magic \"TCMB\"; reads {OLDEST_READ_VERSION} to {FORMAT_VERSION})",
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
            "  {:<19} {} (a loaded model)",
            "Hub",
            bytes(size_of::<Hub>())
        );
        println!(
            "  {:<19} {} (static RAM: hub + filters + limiter)",
            "Pipeline",
            bytes(size_of::<firmware::pipeline::Pipeline>())
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

    /// Panics (none are expected: the library is panic-free by its tests)
    /// log one line over RTT and stop in a UDF trap: an attached probe-rs
    /// prints the backtrace (where it happened); unattached, the watchdog
    /// resets the hub. The panic's message and location are not logged:
    /// keeping them costs 4.2 KB of flash (file paths and message pieces of
    /// every panic site, and `core::fmt` if formatted, as panic-probe's
    /// `print-defmt` does). `defmt::panic!` logs its own message first.
    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        defmt::error!("panic: see the backtrace (probe-rs)");
        cortex_m::asm::udf()
    }

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

/// Board glue that is not a task: the flash adapter, the shared chip
/// selects, the RTD bank, and the per-sample work with and without the
/// model (feature `model`), so the RTIC app below stays the same in both.
#[cfg(target_os = "none")]
mod glue {
    use stm32f4xx_hal::gpio::{AnyPin, Output};
    #[cfg(feature = "model")]
    use {
        core::{cell::RefCell, convert::Infallible},
        embedded_hal::delay::DelayNs,
        embedded_hal::digital::{ErrorType, OutputPin},
        embedded_storage::nor_flash::{ErrorType as FlashErrorType, NorFlash, ReadNorFlash},
        firmware::board,
        stm32f4xx_hal::flash::{Error as FlashError, FlashExt, LockedFlash},
    };

    /// An RTD chip-select pin.
    pub type CsPin = AnyPin<Output>;

    #[cfg(feature = "model")]
    /// The board flash for the uploader: unlocked only for the duration of
    /// one erase or write (the HAL's `UnlockedFlash` relocks on drop).
    pub struct BoardFlash(pub LockedFlash);

    #[cfg(feature = "model")]
    impl FlashErrorType for BoardFlash {
        type Error = FlashError;
    }

    #[cfg(feature = "model")]
    impl ReadNorFlash for BoardFlash {
        const READ_SIZE: usize = 1;

        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            ReadNorFlash::read(&mut self.0, offset, bytes)
        }

        fn capacity(&self) -> usize {
            ReadNorFlash::capacity(&self.0)
        }
    }

    #[cfg(feature = "model")]
    impl NorFlash for BoardFlash {
        const WRITE_SIZE: usize = 1;
        const ERASE_SIZE: usize = 128 * 1024;

        fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
            NorFlash::erase(&mut self.0.unlocked(), from, to)
        }

        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
            NorFlash::write(&mut self.0.unlocked(), offset, bytes)
        }
    }

    #[cfg(feature = "model")]
    impl firmware::upload::MappedFlash for BoardFlash {
        /// The memory-mapped flash (the HAL's `FlashExt::read`): the commit
        /// checks a blob in place, with no 16 KiB copy in RAM.
        fn mapped(&self) -> &[u8] {
            FlashExt::read(&self.0)
        }
    }

    #[cfg(feature = "model")]
    /// A chip select shared by reference, so a new `SpiDevice` for a chip
    /// can be made after `Max31865::new` failed and dropped the old one.
    #[derive(Clone, Copy)]
    pub struct SharedCs<'a>(pub &'a RefCell<CsPin>);

    #[cfg(feature = "model")]
    impl ErrorType for SharedCs<'_> {
        type Error = Infallible;
    }

    #[cfg(feature = "model")]
    impl OutputPin for SharedCs<'_> {
        fn set_low(&mut self) -> Result<(), Infallible> {
            self.0.borrow_mut().set_low();
            Ok(())
        }

        fn set_high(&mut self) -> Result<(), Infallible> {
            self.0.borrow_mut().set_high();
            Ok(())
        }
    }

    #[cfg(feature = "model")]
    /// Busy-wait delay in core cycles for the SPI devices: SysTick belongs
    /// to the monotonic, and each device needs its own delay by value. The
    /// MAX31865 driver issues no delay operations, so it never runs.
    #[derive(Clone, Copy)]
    pub struct CycleDelay;

    #[cfg(feature = "model")]
    impl DelayNs for CycleDelay {
        fn delay_ns(&mut self, ns: u32) {
            // 180 cycles per us; at least `ns` long (asm::delay waits >= n cycles).
            let cycles = u64::from(ns) * u64::from(board::SYSCLK_HZ / 1_000_000) / 1000 + 1;
            cortex_m::asm::delay(u32::try_from(cycles).unwrap_or(u32::MAX));
        }
    }

    /// What `emit` gets after each sample.
    #[derive(Clone, Copy)]
    pub struct Sampled {
        pub report: firmware::report::Report,
        pub info: firmware::can_frames::StatusInfo,
        /// Raw temperatures in model input order (NaN: not a temperature or not read).
        pub temps_c: [f64; firmware::offsets::MAX_INPUTS],
    }

    #[cfg(feature = "model")]
    pub use with_model::*;
    #[cfg(not(feature = "model"))]
    pub use without_model::*;

    #[cfg(feature = "model")]
    mod with_model {
        use super::{CsPin, CycleDelay, Sampled, SharedCs};
        use core::cell::RefCell;
        use embedded_hal_bus::spi::RefCellDevice;
        use firmware::can_frames::StatusInfo;
        use firmware::cnc_inputs::CncInputs;
        use firmware::commands::{self, Event, SharedPipeline};
        use firmware::offsets::MAX_INPUTS;
        use firmware::pipeline::{Pipeline, Reading};
        use firmware::protocol::{Command, HubMessage};
        use firmware::rtd::Converter;
        use firmware::upload::Uploader;
        use firmware::{board, hub};
        use max31865::{Config, Filter, Mode, Wires};
        use stm32f4xx_hal::{pac, spi::Spi};

        /// What the sampling task and the command task share.
        pub type Core = Pipeline;
        /// The upload state machine over the board flash.
        pub type Upload = Uploader<super::BoardFlash>;
        /// SPI1 and the chip selects, handed to `sample`.
        pub type RtdHw = (Spi<pac::SPI1>, [CsPin; board::RTD_CHANNELS]);
        /// One converter's device: SPI1 borrowed per transaction.
        pub type RtdDevice<'a> = RefCellDevice<'a, Spi<pac::SPI1>, SharedCs<'a>, CycleDelay>;
        /// All converters.
        pub type Bank<'a> = [Converter<RtdDevice<'a>>; board::RTD_CHANNELS];
        /// The values received from the CNC, shared by `can_rx` and `sample`.
        pub type Cnc = CncInputs;

        /// Nothing received yet; values valid for `timeout_ms` (object 0x2007).
        pub const fn new_cnc(timeout_ms: u32) -> Cnc {
            CncInputs::new(timeout_ms)
        }

        /// The CNC's values from an RPDO (or an SDO write) into the store
        /// (`can_rx` task).
        pub fn receive(cnc: &mut Cnc, msg: &firmware::can_rx::RxMessage, now_ms: u32) {
            cnc.receive(msg, now_ms);
        }

        /// What `sample` takes from the store under its lock: a copy (old
        /// values expired first) and the tool length received since the
        /// last sample.
        pub fn take_cnc(cnc: &mut Cnc, now_ms: u32) -> (Cnc, Option<f64>) {
            cnc.expire(now_ms);
            let tool_mm = cnc.take_tool_mm();
            (*cnc, tool_mm)
        }

        /// Every converter: auto conversions, the board's wiring and mains
        /// filter, full-range fault window (only open/short trip it).
        pub const RTD_CONFIG: Config = Config::new(
            match board::RTD_WIRES {
                2 => Wires::Two,
                4 => Wires::Four,
                _ => Wires::Three,
            },
            match board::RTD_MAINS_HZ {
                60 => Filter::Hz60,
                _ => Filter::Hz50,
            },
            Mode::Auto,
        );

        /// First auto conversion after configuration, ms (21 ms max at 50 Hz).
        pub const FIRST_CONVERSION_MS: u32 =
            max31865::conversion_time_us(RTD_CONFIG.filter, Mode::Auto).div_ceil(1000) + 1;

        /// A fresh device for channel `k`.
        pub fn device<'a>(
            bus: &'a RefCell<Spi<pac::SPI1>>,
            cs: &'a [RefCell<CsPin>; board::RTD_CHANNELS],
            k: usize,
        ) -> Option<RtdDevice<'a>> {
            let pin = cs.get(k)?;
            // Drives CS high; infallible.
            RefCellDevice::new(bus, SharedCs(pin), CycleDelay).ok()
        }

        /// Starts every converter that is down; reads back the configuration
        /// of those that are up. Logs each change.
        pub fn service<'a>(
            bank: &mut Bank<'a>,
            bus: &'a RefCell<Spi<pac::SPI1>>,
            cs: &'a [RefCell<CsPin>; board::RTD_CHANNELS],
        ) {
            for (k, ch) in bank.iter_mut().enumerate() {
                if ch.is_up() {
                    if let Err(f) = ch.check() {
                        defmt::warn!(
                            "RTD{=usize}: lost its configuration ({=str}), retrying",
                            k + 1,
                            f.name()
                        );
                    }
                } else if let Some(dev) = device(bus, cs, k) {
                    match ch.start(dev, RTD_CONFIG) {
                        Ok(()) => defmt::info!("RTD{=usize}: up", k + 1),
                        Err(f) => {
                            defmt::debug!("RTD{=usize}: down ({=str})", k + 1, f.name())
                        }
                    }
                }
            }
        }

        /// One sample: latch a tool length received over CAN, read the
        /// converters the model's inputs name and the CNC's values at
        /// `now_ms`, run the pipeline.
        pub fn sample(
            p: &mut Pipeline,
            bank: &mut Bank<'_>,
            (cnc, tool_mm): (Cnc, Option<f64>),
            now_ms: u32,
        ) -> Sampled {
            if let Some(mm) = tool_mm {
                if p.set_tool_length_mm(mm).is_err() {
                    defmt::warn!("CAN1: tool length out of range, the old one stays");
                }
            }
            let n = p.hub().input_count().min(MAX_INPUTS);
            let (readings, temps_c) = firmware::cnc_inputs::gather(p.hub(), &cnc, now_ms, |k| {
                bank.get_mut(k).map_or(Reading::Stale, |ch| ch.read())
            });
            let report = p.on_sample(readings.get(..n).unwrap_or(&[]));
            let faults = p.hub().faults();
            if faults.consecutive == 1 {
                defmt::warn!(
                    "sample {=u32} refused: faulty inputs {=u32:#x}",
                    report.seq,
                    report.faulty_channels
                );
            }
            Sampled {
                report,
                info: StatusInfo {
                    n_inputs: n,
                    consecutive_faults: faults.consecutive,
                },
                temps_c,
            }
        }

        /// The period `sample` runs at, ms.
        pub fn period_ms(p: &Pipeline) -> u32 {
            p.sample_period_ms()
        }

        /// The RTIC lock on the shared pipeline, for `firmware::commands`.
        struct Locked<'m, M>(&'m mut M);

        impl<M: rtic::Mutex<T = &'static mut Pipeline>> SharedPipeline for Locked<'_, M> {
            fn with<R>(&mut self, f: impl FnOnce(&mut Pipeline) -> R) -> R {
                self.0.lock(|p| f(p))
            }
        }

        /// Carries out one command (`firmware::commands`, tested on the
        /// host) and logs what it did; the reply. `feed` runs right before
        /// an upload's erase.
        pub fn command(
            core: &mut impl rtic::Mutex<T = &'static mut Pipeline>,
            uploader: &mut Upload,
            feed: impl FnOnce(),
            cmd: &Command,
        ) -> HubMessage {
            if let Command::UploadBegin { len, .. } = cmd {
                defmt::info!(
                    "upload of {=u32} B: erasing slot (CPU stalls up to {=u32} ms)",
                    *len,
                    board::FLASH_SECTOR_ERASE_MAX_MS
                );
            }
            let mut shared = Locked(core);
            let (reply, event) = commands::execute(&mut shared, uploader, feed, cmd);
            match event {
                Event::Swapped { slot } => {
                    defmt::info!(
                        "upload committed to slot {=str}, new model running",
                        slot.name()
                    );
                    shared.with(|p| log_model(p.hub()));
                }
                Event::SwapRefused { .. } => {
                    defmt::error!("committed model refused by the pipeline")
                }
                Event::Erased { .. } | Event::None => {}
            }
            reply
        }

        /// Boot log of the model: what was loaded, or why nothing was.
        pub fn log_model(hub: &hub::Hub) {
            match (hub.model(), hub.load_error()) {
                (Some(model), _) => {
                    defmt::info!(
                        "model {=str}: {=usize} inputs, {=usize} outputs",
                        model.kind().name(),
                        model.inputs().len(),
                        model.outputs().len()
                    );
                    for (j, input) in model.inputs().iter().enumerate() {
                        match board::rtd_channel(input.name.as_str()) {
                            Some(k) => defmt::info!(
                                "  input {=usize} {=str} <- RTD{=usize}",
                                j,
                                input.name.as_str(),
                                k + 1
                            ),
                            // Speed, power, tool length, a position: from
                            // the CNC (`cnc_inputs`); anything else: stale.
                            None => defmt::info!(
                                "  input {=usize} {=str} (not an RTD)",
                                j,
                                input.name.as_str()
                            ),
                        }
                    }
                }
                (None, Some(error)) => defmt::warn!("no model: {}", error),
                (None, None) => defmt::warn!("no model"),
            }
        }
    }

    /// Without model support: no converters, NoModel reports, commands
    /// other than Ping refused.
    #[cfg(not(feature = "model"))]
    mod without_model {
        use super::Sampled;
        use firmware::can_frames::StatusInfo;
        use firmware::offsets::MAX_INPUTS;
        use firmware::protocol::{Command, ErrorCode, HubMessage, PROTOCOL_VERSION};
        use firmware::report::{Report, StatusFlags};

        /// The sample counter.
        pub type Core = u32;
        pub type Upload = ();
        pub type RtdHw = ();
        pub type Bank<'a> = ();
        /// Nothing from the CNC is used without a model.
        pub type Cnc = ();

        pub const fn new_cnc(_timeout_ms: u32) -> Cnc {}

        pub fn receive(_cnc: &mut Cnc, _msg: &firmware::can_rx::RxMessage, _now_ms: u32) {}

        pub fn take_cnc(_cnc: &mut Cnc, _now_ms: u32) -> (Cnc, Option<f64>) {
            ((), None)
        }

        pub fn sample(
            seq: &mut u32,
            _bank: &mut (),
            _cnc: (Cnc, Option<f64>),
            _now_ms: u32,
        ) -> Sampled {
            let report = Report {
                seq: *seq,
                flags: StatusFlags(StatusFlags::NO_MODEL),
                ..Report::default()
            };
            *seq = seq.wrapping_add(1);
            Sampled {
                report,
                info: StatusInfo::default(),
                temps_c: [f64::NAN; MAX_INPUTS],
            }
        }

        pub fn period_ms(_: &u32) -> u32 {
            firmware::board::SAMPLE_PERIOD_MS
        }

        pub fn command(
            _core: &mut impl rtic::Mutex<T = &'static mut u32>,
            _uploader: &mut (),
            _feed: impl FnOnce(),
            cmd: &Command,
        ) -> HubMessage {
            match cmd {
                Command::Ping => HubMessage::Pong {
                    protocol: PROTOCOL_VERSION,
                },
                other => HubMessage::Nack {
                    command: other.kind(),
                    error: ErrorCode::Unsupported,
                },
            }
        }
    }
}

/// The RTIC v2 application (board only).
#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true, dispatchers = [UART4, UART5])]
mod app {
    use crate::glue::{self, Cnc, Core, RtdHw, Sampled, Upload};
    use crate::rt::Mono;
    use bxcan::filter::ListEntry16;
    use bxcan::{Frame, Mailbox};
    use core::mem::MaybeUninit;
    use firmware::canopen::{Event, Node, Settings};
    use firmware::protocol::{
        self, Command, CommandKind, ErrorCode, FrameError, FrameReader, HubMessage, Telemetry,
        COMMAND_FRAME_MAX, HUB_FRAME_MAX,
    };
    use firmware::{board, layout};
    use rtic_monotonics::Timebase;
    use rtic_sync::channel::{Receiver, Sender};
    use stm32f4xx_hal::{
        can::{Can, CanExt},
        gpio::GpioExt,
        hal::spi::MODE_1,
        hal_02::blocking::serial::Write as _,
        hal_02::serial::Read as _,
        pac,
        prelude::_fugit_ExtU32,
        rcc::{Config, RccExt},
        serial::{Rx, RxListen, SerialExt, Tx},
        spi::SpiExt,
        time::{Bps, Hertz},
        watchdog::IndependentWatchdog,
    };

    /// A decoded command, or why a frame was dropped.
    type Incoming = Result<Command, FrameError>;
    /// Commands queued between the USART2 interrupt and `command`: the
    /// host waits for each reply, so 4 only matters for garbage frames.
    const COMMAND_QUEUE: usize = 4;
    /// Samples waiting for `emit`: one being sent, one queued; more means
    /// the UART/CAN cannot keep up and the oldest reports are dropped.
    const EMIT_QUEUE: usize = 2;
    /// Tries per CAN frame when all three mailboxes are busy, 1 ms apart
    /// (a frame takes ~0.25 ms at 500 kbit/s).
    const CAN_TX_TRIES: u32 = 5;

    #[shared]
    struct Shared {
        /// The pipeline (or the sample counter without the model).
        core: &'static mut Core,
        watchdog: IndependentWatchdog,
        tx: Tx<pac::USART2>,
        /// CAN1: `emit` transmits, `can_rx` receives.
        can: bxcan::Can<Can<pac::CAN1>>,
        /// The CNC's values as received (`can_rx`), read by `sample`.
        cnc: Cnc,
        /// The CANopen node: `can_rx` hands it frames, `emit` samples.
        node: Node,
        /// Model uploads (`command`) and settings saves (`store`) share the flash.
        uploader: Upload,
        /// A settings save is queued or running (`store`); an NMT reset
        /// node that arrives meanwhile waits for it (`reset_after_save`).
        saving: bool,
        /// NMT reset node arrived during a save: `store` resets when done.
        reset_after_save: bool,
    }

    #[local]
    struct Local {
        /// SPI1 and the chip selects, taken by `sample` when it starts.
        rtd_hw: Option<RtdHw>,
        rx: Rx<pac::USART2>,
        cmd_tx: Sender<'static, Incoming, COMMAND_QUEUE>,
        cmd_rx: Receiver<'static, Incoming, COMMAND_QUEUE>,
        sampled_tx: Sender<'static, Sampled, EMIT_QUEUE>,
        sampled_rx: Receiver<'static, Sampled, EMIT_QUEUE>,
    }

    // `core_slot` starts uninitialised (.bss, not flash); `MaybeUninit::write`
    // fills it once and hands out the `&'static mut` the tasks share.
    #[init(local = [core_slot: MaybeUninit<Core> = MaybeUninit::uninit()])]
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

        let (core, uploader, settings) = boot(dp.FLASH, cx.local.core_slot);
        let node = match Node::new(settings) {
            Ok(n) => n,
            // `store::latest` checked stored settings as the node does;
            // the defaults are checked by the library's tests.
            Err(_) => defmt::panic!("settings refused by the dictionary"),
        };

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);

        let uart = dp
            .USART2
            .serial((gpioa.pa2, gpioa.pa3), Bps(board::UART_BAUD), &mut rcc)
            .unwrap();
        let (tx, mut rx) = uart.split();
        rx.listen();

        // SPI1 and the chip selects (board::RTD_CS_PINS order), all idle high
        // before any chip is addressed.
        const _: () = assert!(board::RTD_SPI_MODE == 1);
        let spi = dp.SPI1.spi(
            (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
            MODE_1,
            Hertz::from_raw(board::RTD_SPI_HZ),
            &mut rcc,
        );
        let cs = [
            gpiob.pb6.into_push_pull_output().erase(),
            gpioc.pc7.into_push_pull_output().erase(),
            gpioa.pa9.into_push_pull_output().erase(),
            gpioa.pa8.into_push_pull_output().erase(),
            gpiob.pb10.into_push_pull_output().erase(),
            gpiob.pb4.into_push_pull_output().erase(),
            gpiob.pb5.into_push_pull_output().erase(),
            gpioa.pa10.into_push_pull_output().erase(),
        ]
        .map(|mut pin| {
            pin.set_high();
            pin
        });
        let rtd_hw = rtd_hw(spi, cs);

        // `leave_disabled` instead of `enable`: `enable` blocks until it sees 11
        // recessive bits, which never happens without a transceiver. `emit`
        // finishes enabling without blocking.
        let mut can = bxcan::Can::builder(dp.CAN1.can((gpioa.pa12, gpioa.pa11), &mut rcc))
            .set_bit_timing(board::CAN_TIMING.btr())
            .leave_disabled();
        // Only the node's frames reach FIFO 0 (list mode: exact ids, data
        // frames: NMT, SDO request, RPDO1, RPDO2); its interrupt wakes `can_rx`.
        let entry = |id: u16| match bxcan::StandardId::new(id) {
            Some(id) => ListEntry16::data_frames_with_id(id),
            None => defmt::panic!("CAN id beyond 11 bits"),
        };
        can.modify_filters()
            .enable_bank(0, bxcan::Fifo::Fifo0, node.rx_ids().map(entry));
        can.enable_interrupt(bxcan::Interrupt::Fifo0MessagePending);

        let (cmd_tx, cmd_rx) = rtic_sync::make_channel!(Incoming, COMMAND_QUEUE);
        let (sampled_tx, sampled_rx) = rtic_sync::make_channel!(Sampled, EMIT_QUEUE);

        // Last: from here on `sample` must feed it at least every IWDG timeout.
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.stop_on_debug(&dp.DBGMCU, true);
        watchdog.start(board::IWDG_TIMEOUT_MS.millis());

        defmt::info!(
            "init: sysclk {=u32} Hz, pclk1 {=u32} Hz, sample period {=u32} ms",
            clocks.sysclk().raw(),
            clocks.pclk1().raw(),
            glue::period_ms(core)
        );
        sample::spawn().ok();
        command::spawn().ok();
        emit::spawn().ok();

        (
            Shared {
                core,
                watchdog,
                tx,
                can,
                cnc: glue::new_cnc(settings.cnc_timeout_ms),
                node,
                uploader,
                saving: false,
                reset_after_save: false,
            },
            Local {
                rtd_hw,
                rx,
                cmd_tx,
                cmd_rx,
                sampled_tx,
                sampled_rx,
            },
        )
    }

    /// Boots the pipeline in its static (`firmware::boot`: the slot to boot
    /// picked, its model loaded in place) and builds the uploader.
    #[cfg(feature = "model")]
    fn boot(
        flash: pac::FLASH,
        slot: &'static mut MaybeUninit<Core>,
    ) -> (&'static mut Core, Upload, Settings) {
        use firmware::pipeline::PipelineConfig;
        use firmware::upload::{Slot, SlotMap, Uploader};
        use stm32f4xx_hal::flash::FlashExt;

        // The slots as byte slices of the memory-mapped flash (no `unsafe`:
        // the HAL's `FlashExt::read`). A flash smaller than the layout
        // expects gives empty slots, which load as "no model".
        let bytes = flash.read();
        let region = |r: layout::Region| {
            let start = (r.origin - layout::FLASH_BASE) as usize;
            bytes.get(start..start + r.len as usize).unwrap_or(&[])
        };
        // The settings last saved over CANopen (0x1010), else the defaults.
        let settings = match firmware::canopen::store::latest(region(layout::SETTINGS)) {
            Some((seq, s)) => {
                defmt::info!("CANopen settings: record {=u32}", seq);
                s
            }
            None => Settings::DEFAULT,
        };
        let Ok(config) = settings.pipeline_config(PipelineConfig::DEFAULT).checked() else {
            // The settings passed the dictionary's checks, which include the
            // pipeline's cross-checks; the defaults are checked by tests.
            defmt::panic!("pipeline config refused")
        };
        let slots = [region(layout::MODEL_A), region(layout::MODEL_B)];
        let (pipeline, active) = firmware::boot::boot(slot, config, slots);
        defmt::info!("boot slot: {=str}", active.map_or("none", Slot::name));
        glue::log_model(pipeline.hub());
        let flash = glue::BoardFlash(stm32f4xx_hal::flash::LockedFlash::new(flash));
        (
            pipeline,
            Uploader::new(flash, SlotMap::BOARD, active),
            settings,
        )
    }

    #[cfg(not(feature = "model"))]
    fn boot(
        _flash: pac::FLASH,
        slot: &'static mut MaybeUninit<Core>,
    ) -> (&'static mut Core, Upload, Settings) {
        defmt::info!("model support not built in: offsets stay zero");
        (slot.write(0), (), Settings::DEFAULT)
    }

    #[cfg(feature = "model")]
    fn rtd_hw(
        spi: stm32f4xx_hal::spi::Spi<pac::SPI1>,
        cs: [glue::CsPin; board::RTD_CHANNELS],
    ) -> Option<RtdHw> {
        Some((spi, cs))
    }

    #[cfg(not(feature = "model"))]
    fn rtd_hw(
        _spi: stm32f4xx_hal::spi::Spi<pac::SPI1>,
        _cs: [glue::CsPin; board::RTD_CHANNELS],
    ) -> Option<RtdHw> {
        None
    }

    /// Periodic sampling from a fixed start (no drift): read the converters
    /// the model needs, run the pipeline, feed the watchdog, hand the
    /// result to `emit`. Converters are configured at the start and then
    /// serviced every `board::RTD_RETRY_MS`.
    #[task(priority = 2, shared = [core, watchdog, cnc], local = [rtd_hw, sampled_tx])]
    async fn sample(mut cx: sample::Context) {
        #[cfg(feature = "model")]
        let (bus, cs) = {
            // Taken once: this task never ends.
            let Some((spi, pins)) = cx.local.rtd_hw.take() else {
                defmt::panic!("sample started twice");
            };
            // Lives as long as this never-ending task (its future is static).
            (
                core::cell::RefCell::new(spi),
                pins.map(core::cell::RefCell::new),
            )
        };
        #[cfg(feature = "model")]
        let mut bank: glue::Bank<'_> = core::array::from_fn(|_| firmware::rtd::Converter::down());
        #[cfg(feature = "model")]
        {
            glue::service(&mut bank, &bus, &cs);
            Mono::delay(ms(glue::FIRST_CONVERSION_MS)).await;
        }
        #[cfg(not(feature = "model"))]
        let mut bank: glue::Bank<'_> = ();
        #[cfg(not(feature = "model"))]
        let _ = cx.local.rtd_hw.take();

        let retry = ms(board::RTD_RETRY_MS);
        let feed_every = ms(board::SAMPLE_PERIOD_MS);
        let mut next = Mono::now();
        let mut next_service = next + retry;
        loop {
            let now_ms = Mono::now().as_ticks();
            let cnc = cx.shared.cnc.lock(|c| glue::take_cnc(c, now_ms));
            let (sampled, period_ms) = cx.shared.core.lock(|core| {
                (
                    glue::sample(core, &mut bank, cnc, now_ms),
                    glue::period_ms(core),
                )
            });
            cx.shared.watchdog.lock(|w| w.feed());
            if cx.local.sampled_tx.try_send(sampled).is_err() {
                defmt::warn!(
                    "emit still busy, sample {=u32} not reported",
                    sampled.report.seq
                );
            }

            let now = Mono::now();
            if now >= next_service {
                #[cfg(feature = "model")]
                glue::service(&mut bank, &bus, &cs);
                next_service = now + retry;
            }

            // Next deadline from the fixed start; after a stall (flash erase)
            // skip the missed ones rather than sample in a burst.
            let period = ms(period_ms);
            next += period;
            let mut skipped = 0u32;
            while next <= Mono::now() {
                next += period;
                skipped += 1;
            }
            if skipped > 0 {
                defmt::warn!("{=u32} samples skipped (CPU stalled)", skipped);
            }
            // Sleep, feeding the watchdog at least every SAMPLE_PERIOD_MS so a
            // model with a longer dt_s does not trip it.
            loop {
                let now = Mono::now();
                if now >= next {
                    break;
                }
                let wake = if next - now > feed_every {
                    now + feed_every
                } else {
                    next
                };
                Mono::delay_until(wake).await;
                cx.shared.watchdog.lock(|w| w.feed());
            }
        }
    }

    /// USART2 receive: bytes into the COBS frame reader, decoded commands
    /// (and dropped frames) to `command`. Highest priority: at 115200 baud
    /// a byte arrives every 87 us and the USART holds only one.
    #[task(binds = USART2, priority = 3, local = [rx, cmd_tx, reader: FrameReader<COMMAND_FRAME_MAX> = FrameReader::new()])]
    fn usart2(cx: usart2::Context) {
        loop {
            match cx.local.rx.read() {
                Ok(byte) => {
                    if let Some(incoming) = cx.local.reader.push::<Command>(byte) {
                        if cx.local.cmd_tx.try_send(incoming).is_err() {
                            defmt::warn!("command queue full, frame dropped");
                        }
                    }
                }
                // Nothing left to read.
                Err(stm32f4xx_hal::nb::Error::WouldBlock) => break,
                // Overrun/noise/framing (cleared by the read): the frame in
                // progress will fail to decode and be refused.
                Err(stm32f4xx_hal::nb::Error::Other(_)) => {}
            }
        }
    }

    /// The node's frames (`can_rx`): NMT, SDO, RPDOs through
    /// `canopen::Node`; the CNC's values stored with their arrival time for
    /// `sample`, SDO responses sent at once. Same priority as `usart2`;
    /// both are short.
    #[task(binds = CAN1_RX0, priority = 3, shared = [can, cnc, node, saving, reset_after_save])]
    fn can_rx(mut cx: can_rx::Context) {
        let now_ms = Mono::now().as_ticks();
        loop {
            // FIFO 0 only: the filter routes nothing to FIFO 1.
            match cx.shared.can.lock(|can| can.rx0().receive()) {
                Ok(frame) => {
                    let reaction = cx.shared.node.lock(|n| n.on_frame(&frame, now_ms));
                    for f in &reaction.frames {
                        // No waiting in an interrupt: with all three
                        // mailboxes busy the response is lost and the SDO
                        // client times out and retries.
                        // bxcan may dequeue a pending frame of lower priority
                        // (a higher id) to make room: that frame is lost.
                        match cx.shared.can.lock(|can| can.transmit(f)) {
                            Ok(st) if st.dequeued_frame().is_none() => {}
                            _ => defmt::debug!("CAN1: response not queued, or displaced a frame"),
                        }
                    }
                    match reaction.event {
                        Some(Event::Input(msg)) => {
                            cx.shared.cnc.lock(|cnc| glue::receive(cnc, &msg, now_ms))
                        }
                        // A PLC sends "save" and then at once "reset node":
                        // the reset waits for the save to reach the flash.
                        Some(Event::ResetNode) => {
                            if cx.shared.saving.lock(|s| *s) {
                                cx.shared.reset_after_save.lock(|r| *r = true);
                            } else {
                                cortex_m::peripheral::SCB::sys_reset();
                            }
                        }
                        Some(Event::Store(s)) => {
                            if store::spawn(s).is_ok() {
                                cx.shared.saving.lock(|s| *s = true);
                            } else {
                                defmt::warn!("CANopen: a save is still running, this one dropped");
                            }
                        }
                        _ => {}
                    }
                }
                Err(stm32f4xx_hal::nb::Error::WouldBlock) => break,
                // The flag is cleared by the read; the frames still queued follow.
                Err(stm32f4xx_hal::nb::Error::Other(_)) => {
                    defmt::warn!("CAN1: receive FIFO overrun, a frame from the CNC lost")
                }
            }
        }
    }

    /// Serial commands, lowest priority: uploads (the erase stalls the CPU),
    /// tool length, ping. One reply per command.
    #[task(priority = 1, shared = [core, watchdog, tx, uploader], local = [cmd_rx])]
    async fn command(mut cx: command::Context) {
        while let Ok(incoming) = cx.local.cmd_rx.recv().await {
            let reply = match incoming {
                Ok(cmd) => {
                    let watchdog = &mut cx.shared.watchdog;
                    let core = &mut cx.shared.core;
                    cx.shared.uploader.lock(|uploader| {
                        glue::command(core, uploader, || watchdog.lock(|w| w.feed()), &cmd)
                    })
                }
                Err(_) => HubMessage::Nack {
                    command: CommandKind::Unknown,
                    error: ErrorCode::Malformed,
                },
            };
            send(&mut cx.shared.tx, &reply);
        }
    }

    /// Settings saved by SDO 0x1010 (or restored by 0x1011) into the
    /// settings sector; they apply at the next reset. Priority 1: a full
    /// sector is erased first (1-2 s CPU stall, once every 1024 saves).
    #[task(priority = 1, shared = [watchdog, uploader, saving, reset_after_save])]
    async fn store(mut cx: store::Context, settings: Settings) {
        #[cfg(feature = "model")]
        {
            let region = layout::SETTINGS;
            cx.shared.watchdog.lock(|w| w.feed());
            let saved = cx.shared.uploader.lock(|u| {
                firmware::canopen::store::save(
                    u.flash_mut(),
                    region.origin - layout::FLASH_BASE,
                    region.len,
                    &settings,
                )
            });
            cx.shared.watchdog.lock(|w| w.feed());
            match saved {
                Ok(seq) => defmt::info!("CANopen settings saved (record {=u32})", seq),
                Err(_) => defmt::error!("CANopen settings not saved: flash failed"),
            }
        }
        #[cfg(not(feature = "model"))]
        {
            let _ = settings;
            defmt::warn!("CANopen settings not saved: built without the model path");
        }
        cx.shared.saving.lock(|s| *s = false);
        if cx.shared.reset_after_save.lock(|r| *r) {
            cortex_m::peripheral::SCB::sys_reset();
        }
    }

    /// One message as a COBS frame on USART2 (blocking: ~13 ms for the
    /// longest telemetry frame at 115200 baud, at priority 1).
    fn send(tx: &mut impl rtic::Mutex<T = Tx<pac::USART2>>, msg: &HubMessage) {
        let mut buf = [0u8; HUB_FRAME_MAX];
        match protocol::encode(msg, &mut buf) {
            Ok(n) => {
                let frame = buf.get(..n).unwrap_or(&[]);
                if tx.lock(|tx| tx.bwrite_all(frame)).is_err() {
                    defmt::warn!("USART2 write failed");
                }
            }
            Err(_) => defmt::error!("message does not fit HUB_FRAME_MAX"),
        }
    }

    /// Report one sample: telemetry on USART2; OFFSETS/STATUS(/OFFSETS_EXT)
    /// and the heartbeat on CAN1. Lower priority than `sample`, so a slow
    /// UART or a busy bus never delays sampling.
    #[task(priority = 1, shared = [tx, can, node], local = [sampled_rx, can_up: bool = false])]
    async fn emit(mut cx: emit::Context) {
        while let Ok(s) = cx.local.sampled_rx.recv().await {
            report(
                &mut cx.shared.tx,
                &mut cx.shared.can,
                &mut cx.shared.node,
                cx.local.can_up,
                &s,
            )
            .await;
        }
    }

    /// One sample out on USART2 and CAN1.
    async fn report(
        tx: &mut impl rtic::Mutex<T = Tx<pac::USART2>>,
        can: &mut impl rtic::Mutex<T = bxcan::Can<Can<pac::CAN1>>>,
        node: &mut impl rtic::Mutex<T = Node>,
        can_up: &mut bool,
        s: &Sampled,
    ) {
        let n = (s.info.n_inputs).min(s.temps_c.len());
        let telemetry = Telemetry::new(&s.report, s.temps_c.get(..n).unwrap_or(&[]));
        send(tx, &HubMessage::Telemetry(telemetry));

        if !*can_up {
            *can_up = can.lock(|can| can.enable_non_blocking().is_ok());
            if !*can_up {
                defmt::debug!("CAN1 waiting for bus idle");
                return;
            }
            defmt::info!("CAN1 on bus");
            // CANopen boot-up (CiA 301 §7.2.8.3.2.1), once the bus is there.
            let now_ms = Mono::now().as_ticks();
            if let Some(up) = node.lock(|n| n.boot::<Frame>(now_ms)) {
                transmit(can, &up).await;
            }
        }
        // Frames still pending from the last sample are a period old (no
        // ACK on the bus): drop them so fresh ones go out when it recovers.
        can.lock(|can| {
            for mailbox in [Mailbox::Mailbox0, Mailbox::Mailbox1, Mailbox::Mailbox2] {
                can.abort(mailbox);
            }
        });
        // Ascending ids, so a later frame never displaces an earlier one.
        let mut sent = 0u32;
        let frames = node.lock(|n| n.on_sample::<Frame>(&s.report, &s.info));
        let now_ms = Mono::now().as_ticks();
        let heartbeat = node.lock(|n| n.poll_heartbeat::<Frame>(now_ms));
        for frame in frames.iter().chain(heartbeat.as_ref()) {
            if transmit(can, frame).await {
                sent += 1;
            }
        }
        let wanted = frames.len() as u32 + u32::from(heartbeat.is_some());
        if sent < wanted {
            defmt::warn!(
                "CAN1: {=u32} of {=u32} frames not queued (bus off or no ACK?)",
                wanted - sent,
                wanted
            );
        }
    }

    /// A duration of `n` monotonic ticks (ms, `board::MONO_HZ`).
    fn ms(n: u32) -> <Mono as Timebase>::Duration {
        <Mono as Timebase>::Duration::from_ticks(n)
    }

    /// Queues one frame, waiting up to `CAN_TX_TRIES` ms for a free mailbox.
    async fn transmit(
        can: &mut impl rtic::Mutex<T = bxcan::Can<Can<pac::CAN1>>>,
        frame: &Frame,
    ) -> bool {
        for _ in 0..CAN_TX_TRIES {
            match can.lock(|can| can.transmit(frame)) {
                Ok(_) => return true,
                Err(stm32f4xx_hal::nb::Error::WouldBlock) => Mono::delay(ms(1)).await,
                Err(stm32f4xx_hal::nb::Error::Other(never)) => match never {},
            }
        }
        false
    }
}
