//! Time stamps from SysTick and the DWT cycle counter.
//!
//! SysTick runs from the core clock with the largest reload (2^24 - 1) and
//! its interrupt counts wraps, so a [`Stamp`] is a 64-bit tick count. Under
//! QEMU (`-icount shift=0`) a tick is [`QEMU_INSN_PER_TICK`] guest
//! instructions; on the board a tick is one core cycle. DWT CYCCNT counts core
//! cycles on the board and reads 0 under QEMU (QEMU 7.2 does not model it).

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{DWT, SYST};
use cortex_m_rt::exception;

/// SysTick reload: the full 24 bits, so it wraps as rarely as possible.
pub const RELOAD: u32 = 0x00FF_FFFF;
/// Ticks between two wraps.
const PERIOD: u64 = RELOAD as u64 + 1;

/// The mps2 boards' SYSCLK, which QEMU feeds to SysTick's core clock source
/// (QEMU hw/arm/mps2.c, `SYSCLK_FRQ`).
pub const QEMU_SYSCLK_HZ: u64 = 25_000_000;
/// Guest instructions per SysTick tick under `-icount shift=0` (1 ns per
/// instruction, 40 ns per tick at 25 MHz); checked by the `verify` lines of
/// the bench against a loop of known length.
pub const QEMU_INSN_PER_TICK: u64 = 1_000_000_000 / QEMU_SYSCLK_HZ;

/// What one SysTick tick stands for in this build: [`QEMU_INSN_PER_TICK`]
/// guest instructions under QEMU, one core cycle on the STM32F446 (feature
/// `stm32f446`, where SysTick runs from the core clock).
pub const UNITS_PER_TICK: u64 = if cfg!(feature = "stm32f446") {
    1
} else {
    QEMU_INSN_PER_TICK
};

/// SysTick wraps since [`Clock::start`].
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// The running counters.
pub struct Clock {
    _syst: SYST,
    _dwt: DWT,
}

/// A time stamp: SysTick ticks since start and the DWT cycle count.
#[derive(Clone, Copy, Debug)]
pub struct Stamp {
    /// SysTick ticks (core clock) since [`Clock::start`].
    pub ticks: u64,
    /// DWT CYCCNT (wraps at 2^32; 0 under QEMU).
    pub cycles: u32,
}

impl Clock {
    /// Starts SysTick (core clock, full reload, wrap interrupt) and the DWT
    /// cycle counter.
    pub fn start(mut cp: cortex_m::Peripherals) -> Self {
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
        cp.DWT.set_cycle_count(0);
        cp.SYST.disable_counter();
        cp.SYST.set_clock_source(SystClkSource::Core);
        cp.SYST.set_reload(RELOAD);
        cp.SYST.clear_current();
        WRAPS.store(0, Ordering::Relaxed);
        cp.SYST.enable_interrupt();
        cp.SYST.enable_counter();
        Self {
            _syst: cp.SYST,
            _dwt: cp.DWT,
        }
    }

    /// Now. Re-reads if a wrap interrupt came between the two halves.
    #[inline(always)]
    pub fn now(&self) -> Stamp {
        loop {
            let before = WRAPS.load(Ordering::SeqCst);
            let current = SYST::get_current();
            let cycles = DWT::cycle_count();
            if WRAPS.load(Ordering::SeqCst) == before {
                // SysTick counts down from RELOAD.
                let ticks = u64::from(before) * PERIOD + u64::from(RELOAD - current);
                return Stamp { ticks, cycles };
            }
        }
    }
}

/// What `reps` runs of an operation took, and per run.
#[derive(Clone, Copy, Debug)]
pub struct Cost {
    /// Runs timed.
    pub reps: u32,
    /// SysTick ticks for all runs, timing overhead subtracted.
    pub ticks: u64,
    /// DWT cycles for all runs, overhead subtracted (0 under QEMU).
    pub cycles: u64,
}

impl Cost {
    /// SysTick's count per run in [`UNITS_PER_TICK`] units: guest
    /// instructions under QEMU (`-icount shift=0`), core cycles on the board.
    pub fn per_rep(&self) -> f64 {
        (self.ticks * UNITS_PER_TICK) as f64 / f64::from(self.reps.max(1))
    }

    /// DWT cycles per run (the board's number; 0 under QEMU).
    pub fn cycles_per_rep(&self) -> f64 {
        self.cycles as f64 / f64::from(self.reps.max(1))
    }
}

/// Times `reps` calls of `op` in one loop and subtracts `overhead` (the same
/// loop around an empty body, see [`Clock::overhead`]).
#[inline(always)]
pub fn time(clock: &Clock, overhead: &Cost, reps: u32, mut op: impl FnMut()) -> Cost {
    let t0 = clock.now();
    for _ in 0..reps {
        op();
    }
    let t1 = clock.now();
    let raw = Cost {
        reps,
        ticks: t1.ticks - t0.ticks,
        cycles: u64::from(t1.cycles.wrapping_sub(t0.cycles)),
    };
    // The overhead was measured for its own number of runs: scale it.
    let scale = |x: u64| x * u64::from(reps) / u64::from(overhead.reps.max(1));
    Cost {
        reps,
        ticks: raw.ticks.saturating_sub(scale(overhead.ticks)),
        cycles: raw.cycles.saturating_sub(scale(overhead.cycles)),
    }
}

impl Clock {
    /// The cost of the timing loop itself: `reps` runs of an empty body
    /// (a `black_box`, which the real operations also pass through).
    pub fn overhead(&self, reps: u32) -> Cost {
        let zero = Cost {
            reps: 1,
            ticks: 0,
            cycles: 0,
        };
        time(self, &zero, reps, || {
            core::hint::black_box(());
        })
    }
}

/// A loop of `n` iterations of exactly two instructions (`subs`, `bne`),
/// plus a constant call overhead: the yardstick the QEMU method is checked on
/// (the difference between two `n` is exactly twice the difference in `n`).
#[allow(unsafe_code)]
#[inline(never)]
pub fn known_loop(n: u32) {
    if n == 0 {
        return;
    }
    // SAFETY: the asm only decrements a scratch register to zero; it touches
    // no memory and no stack, and leaves the flags clobbered (the default).
    unsafe {
        core::arch::asm!(
            "2:",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) n => _,
            options(nomem, nostack),
        );
    }
}
