//! Cross-check of the SysTick instruction count against an instruction trace
//! (TOOLCHAIN.md): one whole update of the linear model, run once between two
//! marker functions. scripts/qemu-bench.sh runs it under
//! `-singlestep -d exec,nochain` and counts the trace lines between the
//! markers' addresses.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use model_core::ModelState;
use panic_semihosting as _;
use qemu_bench::clock::{Clock, QEMU_INSN_PER_TICK};
use qemu_bench::models::{self, CHANNELS, OUTPUTS};
use qemu_bench::update::{encode_frame, Sample, FRAME_BUF};

// The markers' bodies are `nop`s (inline asm, which the optimiser keeps), one
// and two of them so that the linker cannot fold the two functions into one.

/// Start of the traced region (QEMU's trace names it).
#[no_mangle]
#[inline(never)]
pub extern "C" fn trace_mark_begin() {
    cortex_m::asm::nop();
}

/// End of the traced region.
#[no_mangle]
#[inline(never)]
pub extern "C" fn trace_mark_end() {
    cortex_m::asm::nop();
    cortex_m::asm::nop();
}

#[entry]
fn main() -> ! {
    let Some(cp) = cortex_m::Peripherals::take() else {
        qemu_bench::exit(false)
    };
    let clock = Clock::start(cp);
    let Ok(valid) = models::linear().validate() else {
        hprintln!("error: linear model invalid");
        qemu_bench::exit(false)
    };
    let (a, b) = (Sample::warm(0.0), Sample::warm(0.05));
    let mut state = ModelState::new();
    let mut t = [0.0; CHANNELS];
    let mut out = [0.0; OUTPUTS];
    let mut frame = [0u8; FRAME_BUF];
    a.temperatures(&mut t);
    let _ = valid.step(&mut state, &t, &mut out);

    let t0 = clock.now();
    trace_mark_begin();
    let fault = black_box(&b).temperatures(&mut t);
    let refused = valid.step(&mut state, &t, &mut out).is_err();
    let flags = 1 | (u8::from(fault) << 1) | (u8::from(refused) << 2);
    black_box(encode_frame(&out, &t, flags, &mut frame));
    trace_mark_end();
    let t1 = clock.now();

    hprintln!(
        "trace-check: linear whole update, SysTick {} ticks = {} instructions (+-{})",
        t1.ticks - t0.ticks,
        (t1.ticks - t0.ticks) * QEMU_INSN_PER_TICK,
        QEMU_INSN_PER_TICK
    );
    qemu_bench::exit(true)
}
