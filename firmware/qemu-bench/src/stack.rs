//! Peak stack use of a piece of code, by painting (the "stack high-water
//! mark" of RTOS practice): fill the free stack below the caller with a
//! pattern, run the code, and find the deepest word it overwrote.
//!
//! The figure is the code's own depth below [`peak`]'s frame: every frame
//! it pushes, every by-value temporary (a decoded model passes through
//! several), the exception frame of an interrupt that fires meanwhile is
//! kept out by running the code with interrupts masked. It is a
//! measurement of the paths the code took on this input, not a bound over
//! every path: the bench runs the largest model of each kind, the case the
//! hub's stack must be sized for.

#![allow(unsafe_code)]

use core::hint::black_box;
use core::ptr;

extern "C" {
    /// cortex-m-rt: the lowest address the stack may use (by default the
    /// first byte after the statics).
    static _stack_end: u32;
}

/// The paint: a word that neither a pointer into RAM nor a small integer nor
/// a common float looks like.
const PAINT: u32 = 0xA5C3_5A3C;
/// Bytes just below the stack pointer left unpainted: this function's own
/// calls (`black_box`, the closure's prologue) run there.
const GUARD: usize = 64;

/// Calls `f` from a frame of its own, allocated below the painted top: `f`
/// inlined into [`peak`] would keep its locals in `peak`'s frame, above the
/// stack pointer read there, and they would go uncounted.
#[inline(never)]
fn call<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// Runs `f` with interrupts masked over a stack painted `depth` bytes deep;
/// its result and the bytes of stack it used below this function's frame,
/// or `None` for the bytes if it reached the end of the paint (the depth is
/// then at least `depth`).
///
/// The paint reaches down to `sp - depth`, or to the end of the stack
/// region (cortex-m-rt's `_stack_end`, just above the statics) if that is
/// higher, so it never writes over a static; the result is then `None`
/// sooner.
///
/// # Safety (internal)
///
/// Writes and reads the words from the bottom above to `sp - GUARD`: free
/// stack below the current frame and above every static, which nothing else
/// owns while interrupts are masked.
#[inline(never)]
pub fn peak<R>(depth: usize, f: impl FnOnce() -> R) -> (R, Option<usize>) {
    cortex_m::interrupt::free(|_| {
        let sp = cortex_m::register::msp::read() as usize & !3;
        let stack_end = (&raw const _stack_end as usize + 3) & !3;
        let bottom = sp.saturating_sub(depth).max(stack_end);
        let top = sp.saturating_sub(GUARD).max(bottom);
        let words = (top - bottom) / 4;
        let base = bottom as *mut u32;
        for k in 0..words {
            // SAFETY: free stack below this frame (see above).
            unsafe { ptr::write_volatile(base.add(k), PAINT) };
        }
        let r = black_box(call(f));
        // The lowest word that is no longer paint.
        let first = (0..words)
            // SAFETY: the same words, read back.
            .find(|&k| unsafe { ptr::read_volatile(base.add(k)) } != PAINT)
            .unwrap_or(words);
        let used = (first > 0).then(|| sp - (bottom + 4 * first));
        (r, used)
    })
}
