//! What one hub update costs on a Cortex-M4: the pieces the bench binaries
//! share.
//!
//! * [`models`]: the largest model of each kind the hub accepts, built from
//!   `model_core` types (so the blob encoder and decoder run on them).
//! * [`update`]: the work of one sample: 16 RTD codes to temperatures, one
//!   `ValidModel::step`, and the stand-in for the frame encoder.
//! * [`stack`]: peak stack use of a piece of code, by painting (the
//!   `stack` binary: the hub's command, sample and boot paths).
//! * [`clock`]: SysTick (extended past 24 bits by its wrap interrupt) and the
//!   DWT cycle counter. Under QEMU with `-icount shift=0` one guest
//!   instruction advances virtual time by 1 ns, and SysTick, clocked from the
//!   mps2 machine's 25 MHz SYSCLK, advances one tick per 40 instructions. On
//!   the board SysTick and DWT both count core cycles.
//!
//! docs/firmware-cost.md gives the method, its check and the numbers.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod clock;
pub mod models;
pub mod stack;
pub mod update;

// The firmware library (a dependency for the `stack` binary) brings the
// STM32F446's PAC along, whose `rt` feature makes cortex-m-rt expect its
// interrupt vectors: every binary here links them through this crate.
use stm32f4xx_hal as _;

/// Ends the program: a semihosting exit (QEMU quits with status 0 or 1;
/// probe-rs ends the run), then sleeps if nothing was listening.
pub fn exit(success: bool) -> ! {
    use cortex_m_semihosting::debug;
    debug::exit(if success {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::wfi();
    }
}
