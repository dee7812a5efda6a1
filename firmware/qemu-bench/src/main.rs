//! The bench: cost of one hub update per model kind, and of loading a model.
//!
//! Under QEMU (`cargo run --release`, or scripts/qemu-bench.sh) it prints
//! guest instruction counts; on an STM32F446 (`--features stm32f446`, run
//! with probe-rs) the DWT column holds real core cycles. Output goes over
//! semihosting; the program ends with a semihosting exit, so QEMU returns.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use model_core::blob::{self, MAX_BLOB_LEN};
use model_core::{ModelKind, ModelState};
use panic_semihosting as _;
use qemu_bench::clock::{known_loop, time, Clock, Cost, UNITS_PER_TICK};
use qemu_bench::models::{self, CHANNELS, KINDS, OUTPUTS, WIDE_CHANNELS};
use qemu_bench::update::{encode_frame, Sample, FRAME_BUF};

/// Runs per timed loop of the per-sample operations: SysTick resolves 40
/// instructions under QEMU, so 100 runs resolve 0.4 instruction per run.
const REPS: u32 = 100;
/// Runs of a blob decode (slow: TF validation finds 32 polynomials' roots).
const DECODE_REPS: u32 = 4;
/// Updates run before timing, so TF histories and the ARMA forecaster are
/// past their start-up paths (first sample, warm-up).
const WARM_UP: u32 = 20;
/// What SysTick counts in this build.
const UNIT: &str = if cfg!(feature = "stm32f446") {
    "core cycles"
} else {
    "instructions"
};
/// Core clock of the hub's STM32F446 (firmware/src/board.rs).
const CORE_HZ: f64 = 180e6;
/// Cycles per instruction assumed for the estimate: 1.0 (every instruction
/// single-cycle) to 1.5 (loads, taken branches, multi-cycle integer ops of
/// the soft-float f64 routines and flash wait states partly hidden by ART).
#[cfg(not(feature = "stm32f446"))]
const CPI: (f64, f64) = (1.0, 1.5);

/// Board build: SysTick and DWT both count core cycles (at the reset clock,
/// 16 MHz HSI; the µs column assumes the same cycles at 180 MHz).
#[cfg(feature = "stm32f446")]
const HEADER: [&str; 2] = [
    "| kind | operation | runs | SysTick cycles/run | - | us at 180 MHz | DWT cycles/run |",
    "|---|---|---|---|---|---|---|",
];
#[cfg(not(feature = "stm32f446"))]
const HEADER: [&str; 2] = [
    "| kind | operation | runs | instructions/run (QEMU) | est. cycles (CPI 1.0 - 1.5) | est. us at 180 MHz | DWT cycles/run |",
    "|---|---|---|---|---|---|---|",
];

#[cfg(feature = "stm32f446")]
fn row(kind: &str, op: &str, c: &Cost) {
    let cyc = c.per_rep();
    hprintln!(
        "| {} | {} | {} | {:.0} | - | {:.1} | {:.0} |",
        kind,
        op,
        c.reps,
        cyc,
        cyc / CORE_HZ * 1e6,
        c.cycles_per_rep()
    );
}

#[cfg(not(feature = "stm32f446"))]
fn row(kind: &str, op: &str, c: &Cost) {
    let insn = c.per_rep();
    let (lo, hi) = (insn * CPI.0, insn * CPI.1);
    hprintln!(
        "| {} | {} | {} | {:.0} | {:.0} - {:.0} | {:.1} - {:.1} | {:.0} |",
        kind,
        op,
        c.reps,
        insn,
        lo,
        hi,
        lo / CORE_HZ * 1e6,
        hi / CORE_HZ * 1e6,
        c.cycles_per_rep()
    );
}

/// Checks the instruction count on a loop of known length: the difference
/// between `n` and `n + delta` iterations must be exactly `2 * delta`.
fn verify(clock: &Clock) {
    let none = Cost {
        reps: 1,
        ticks: 0,
        cycles: 0,
    };
    let mut insn = [0u64; 3];
    for (slot, n) in insn.iter_mut().zip([1_000u32, 101_000, 1_001_000]) {
        let c = time(clock, &none, 1, || known_loop(black_box(n)));
        *slot = c.ticks * UNITS_PER_TICK;
        hprintln!(
            "verify: loop of {} iterations (2 instructions each): {} ticks = {} {}, DWT {} cycles",
            n,
            c.ticks,
            *slot,
            UNIT,
            c.cycles
        );
    }
    for (i, delta) in [(1usize, 100_000u64), (2, 1_000_000)] {
        let got = insn[i] - insn[0];
        if cfg!(feature = "stm32f446") {
            hprintln!(
                "verify (board): {} extra iterations: {} SysTick cycles, {:.3} cycles per 2-instruction iteration",
                delta,
                got,
                got as f64 / delta as f64
            );
            continue;
        }
        let want = 2 * delta;
        hprintln!(
            "verify: {} extra iterations: {} instructions measured, {} expected ({:+} ppm)",
            delta,
            got,
            want,
            (got as f64 - want as f64) / want as f64 * 1e6
        );
    }
}

fn bench_kind(clock: &Clock, overhead: &Cost, kind: ModelKind, buf: &mut [u8; MAX_BLOB_LEN]) {
    let name = kind.name();
    let model = models::build(kind);
    let Ok(valid) = model.clone().validate() else {
        hprintln!("error: the {} model does not validate", name);
        return;
    };
    let Ok(len) = blob::encode(&valid, buf) else {
        hprintln!("error: the {} model does not encode", name);
        return;
    };
    let bytes = &buf[..len];

    // Per sample.
    let (a, b) = (Sample::warm(0.0), Sample::warm(0.05));
    // A model wider than 16 channels reads two banks of 16 front ends (the
    // second bank's codes are the first's, which costs the same).
    let (mut ta, mut tb) = ([0.0; WIDE_CHANNELS], [0.0; WIDE_CHANNELS]);
    for half in ta.chunks_exact_mut(CHANNELS) {
        if let Ok(t) = <&mut [f64; CHANNELS]>::try_from(half) {
            a.temperatures(t);
        }
    }
    for half in tb.chunks_exact_mut(CHANNELS) {
        if let Ok(t) = <&mut [f64; CHANNELS]>::try_from(half) {
            b.temperatures(t);
        }
    }
    let n_in = valid.inputs().len();
    let wide = n_in > CHANNELS;
    let mut state = ModelState::new();
    let mut out = [0.0; OUTPUTS];
    for k in 0..WARM_UP {
        let x = if k & 1 == 0 { &ta } else { &tb };
        let _ = valid.step(&mut state, &x[..n_in], &mut out);
    }
    let mut k = 0u32;
    let step = time(clock, overhead, REPS, || {
        k += 1;
        let x = if k & 1 == 0 { &ta } else { &tb };
        let r = valid.step(&mut state, black_box(&x[..n_in]), &mut out);
        black_box((r.is_ok(), &out));
    });
    row(name, "model step", &step);

    let mut t = [0.0; CHANNELS];
    let mut w = [0.0; WIDE_CHANNELS];
    let mut frame = [0u8; FRAME_BUF];
    let update = time(clock, overhead, REPS, || {
        k += 1;
        let s = if k & 1 == 0 { &a } else { &b };
        let mut fault = black_box(s).temperatures(&mut t);
        let x: &[f64] = if wide {
            let (lo, hi) = w.split_at_mut(CHANNELS);
            lo.copy_from_slice(&t);
            fault |= black_box(s).temperatures(&mut t);
            hi.copy_from_slice(&t);
            &w[..n_in]
        } else {
            &t[..n_in]
        };
        let refused = valid.step(&mut state, x, &mut out).is_err();
        let flags = 1 | (u8::from(fault) << 1) | (u8::from(refused) << 2);
        black_box(encode_frame(&out, &t, flags, &mut frame));
    });
    row(name, "**whole update**", &update);

    // Every input back at once after a 20 min outage (the bus that carries
    // them was down): one bridge per input, added to that sample's update.
    // A no-op for every kind but the filter bank.
    let bridge = time(clock, overhead, REPS, || {
        for (i, (v0, v1)) in ta.iter().zip(&tb).take(n_in).enumerate() {
            valid.bridge(&mut state, i, (*v0, *v1), black_box(1200));
        }
        black_box(&state);
    });
    row(name, "bridge, every input back", &bridge);
    let one = time(clock, overhead, REPS, || {
        valid.bridge(&mut state, 0, (ta[0], tb[0]), black_box(1200));
        black_box(&state);
    });
    row(name, "bridge, one input back", &one);

    // Once per model load.
    let decode = time(clock, overhead, DECODE_REPS, || {
        black_box(blob::decode(black_box(bytes)).is_ok());
    });
    let frame_check = time(clock, overhead, DECODE_REPS, || {
        black_box(blob::check_frame(black_box(bytes)).is_ok());
    });
    let clone = time(clock, overhead, DECODE_REPS, || {
        black_box(black_box(&model).clone());
    });
    let clone_validate = time(clock, overhead, DECODE_REPS, || {
        black_box(black_box(&model).clone().validate().is_ok());
    });
    if let model_core::Params::Tf(entries) = &model.params {
        // Validation finds the roots of every entry's denominator and
        // numerator (Durand-Kerner in model_core::poly): time one of each.
        if let Some(e) = entries.first() {
            let den = time(clock, overhead, DECODE_REPS, || {
                black_box(model_core::poly::roots(black_box(&e.b)).is_ok());
            });
            let num = time(clock, overhead, DECODE_REPS, || {
                black_box(model_core::poly::roots(black_box(&e.a)).is_ok());
            });
            hprintln!(
                "load tf: roots of one order-8 denominator {:.0} {}, numerator {:.0}",
                den.per_rep(),
                UNIT,
                num.per_rep()
            );
        }
    }
    let ok = blob::decode(bytes).is_ok();
    let validate = clone_validate.per_rep() - clone.per_rep();
    hprintln!(
        "load {}: blob {} B, decode ok {}, decode+validate {:.0} {} ({:.0} DWT cycles), of which CRC+header {:.0}, validate {:.0}",
        name,
        len,
        ok,
        decode.per_rep(),
        UNIT,
        decode.cycles_per_rep(),
        frame_check.per_rep(),
        validate
    );
}

#[entry]
fn main() -> ! {
    let Some(cp) = cortex_m::Peripherals::take() else {
        hprintln!("error: core peripherals already taken");
        qemu_bench::exit(false)
    };
    let clock = Clock::start(cp);
    hprintln!("qemu-bench: one hub update on a Cortex-M4");
    let overhead = clock.overhead(REPS);
    hprintln!(
        "timing overhead: {} ticks, {} DWT cycles per {} empty runs (subtracted)",
        overhead.ticks,
        overhead.cycles,
        overhead.reps
    );
    verify(&clock);

    // Shared pieces of the update, timed once.
    let (a, b) = (Sample::warm(0.0), Sample::warm(0.05));
    let mut t = [0.0; CHANNELS];
    let mut k = 0u32;
    let rtd = time(&clock, &overhead, REPS, || {
        k += 1;
        let s = if k & 1 == 0 { &a } else { &b };
        black_box(black_box(s).temperatures(&mut t));
    });
    let out = [1.25, -3.5, 12.75];
    let mut frame = [0u8; FRAME_BUF];
    let mut frame_len = 0;
    let enc = time(&clock, &overhead, REPS, || {
        frame_len = encode_frame(black_box(&out), black_box(&t), 1, &mut frame);
    });

    for line in HEADER {
        hprintln!("{}", line);
    }
    row("all", "RTD code -> C, 16 channels", &rtd);
    row("all", "frame encode (stand-in)", &enc);
    hprintln!("frame: {} bytes", frame_len);
    let mut buf = [0u8; MAX_BLOB_LEN];
    for kind in KINDS {
        hprintln!("size {}: {}", kind.name(), models::size_label(kind));
        bench_kind(&clock, &overhead, kind, &mut buf);
    }
    hprintln!("qemu-bench: done");
    qemu_bench::exit(true)
}
