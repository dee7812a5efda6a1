#!/usr/bin/env bash
# Cost of one hub update on a Cortex-M4, estimated under QEMU
# (docs/firmware-cost.md).
#
# Builds firmware/qemu-bench (a crate outside the workspace, thumbv7em only),
# runs it on QEMU's mps2-an386 (Cortex-M4) with `-icount shift=0`, so that
# SysTick counts guest instructions, and prints its table. Then cross-checks
# one number against an instruction trace (`-singlestep -d exec,nochain`).
#
# Then runs the `stack` binary (peak stack use of the hub's boot, command and
# sample paths, by painting) and checks it against the stack budget.
#
# Fails (non-zero) if QEMU or the thumbv7em target is missing, if a run times
# out or panics, if the output lacks an expected line or a check is off, or if
# a path's stack use is over the budget.
#
# Needs: qemu-system-arm (Debian: `apt-get install qemu-system-arm`, 7.2 known
# to work) and `rustup target add thumbv7em-none-eabihf`. Takes a few seconds
# once built (about 25 s for the first build on 2 cores).
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
crate="$root/firmware/qemu-bench"
elf_dir="$crate/target/thumbv7em-none-eabihf/release"
run_timeout_s=60

fail() {
    echo "qemu-bench: FAIL: $*" >&2
    exit 1
}

command -v qemu-system-arm >/dev/null ||
    fail "qemu-system-arm not found (apt-get install qemu-system-arm)"
if command -v rustup >/dev/null; then
    targets="$(rustup target list --installed)"
    grep -qx thumbv7em-none-eabihf <<<"$targets" ||
        fail "target thumbv7em-none-eabihf missing (rustup target add thumbv7em-none-eabihf)"
fi
echo "qemu-bench: $(qemu-system-arm --version | head -n1)"

# -j1: the machine is shared; the build is small.
(cd "$crate" && cargo build --release -j1 --quiet) || fail "build failed"

# Same flags as the runner in firmware/qemu-bench/.cargo/config.toml.
qemu=(qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic
    -monitor none -serial none -icount shift=0
    -semihosting-config enable=on,target=native)

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# 1. The bench.
status=0
timeout "$run_timeout_s" "${qemu[@]}" -kernel "$elf_dir/qemu-bench" >"$work/bench.txt" 2>&1 ||
    status=$?
cat "$work/bench.txt"
[ "$status" -eq 0 ] || fail "bench exited with status $status (124: timeout after ${run_timeout_s} s)"

grep -q '^qemu-bench: done$' "$work/bench.txt" || fail "no 'done' line"
grep -q '^| all | RTD code -> C, 16 channels |' "$work/bench.txt" || fail "no RTD line"
grep -q '^| all | frame encode (stand-in) |' "$work/bench.txt" || fail "no frame line"
for kind in tf bp linear pcr arma fbank; do
    grep -q "^| $kind | model step |" "$work/bench.txt" || fail "no '$kind' step line"
    grep -q "^| $kind | \*\*whole update\*\* |" "$work/bench.txt" || fail "no '$kind' update line"
    grep -q "^load $kind: blob [0-9]* B, decode ok true," "$work/bench.txt" ||
        fail "'$kind' blob did not decode"
done
# The method's check: extra iterations of a 2-instruction loop must count
# 2 instructions each, within one SysTick tick (40 instructions).
n_verify=$(grep -c '^verify: [0-9]* extra iterations' "$work/bench.txt" || true)
[ "$n_verify" -eq 2 ] || fail "expected 2 verify lines, got $n_verify"
awk '/^verify: [0-9]* extra iterations/ {
        got = $5; want = $8; d = got - want; if (d < 0) d = -d;
        if (d > 40) { print "verify off by " d " instructions: " $0; bad = 1 }
    } END { exit bad }' "$work/bench.txt" || fail "instruction-count check failed"

# 2. Cross-check: one linear-model update counted from an instruction trace.
status=0
timeout "$run_timeout_s" "${qemu[@]}" -singlestep -d exec,nochain -D "$work/trace.log" \
    -kernel "$elf_dir/trace-check" >"$work/trace.txt" 2>&1 || status=$?
cat "$work/trace.txt"
[ "$status" -eq 0 ] || fail "trace-check exited with status $status"
systick=$(sed -n 's/.*ticks = \([0-9]*\) instructions.*/\1/p' "$work/trace.txt")
[ -n "$systick" ] || fail "no SysTick count from trace-check"
# With -singlestep each trace line is one executed instruction. Count the
# lines after trace_mark_begin returns and before trace_mark_end is entered:
# the update plus the `bl trace_mark_end`.
traced=$(awk '
    $NF == "trace_mark_begin" { inside = 1; n = 0; next }
    $NF == "trace_mark_end" && inside { print n; exit }
    inside { n++ }' "$work/trace.log")
[ -n "$traced" ] || fail "markers not found in the trace"
diff=$((systick - traced))
echo "trace-check: instruction trace counts $traced instructions between the markers;" \
    "SysTick said $systick (difference $diff: marker calls and the clock reads, +-40 resolution)"
[ "${diff#-}" -le 80 ] || fail "SysTick and trace disagree by $diff instructions"
# Where those instructions go: QEMU names the function of each traced
# instruction; the f64 routines of compiler_builtins (__adddf3, __aeabi_dcmplt,
# ...) and libm's sqrt are the software floating point.
awk '
    $NF == "trace_mark_begin" { inside = 1; next }
    $NF == "trace_mark_end" && inside { exit }
    inside { n++; if ($NF ~ /(df3|aeabi_d|aeabi_[iu]i2d|aeabi_d2|libm4math4sqrt)/) f++ }
    END { printf "trace-check: %d of %d instructions (%.0f %%) are software f64 (compiler_builtins, libm sqrt)\n", f, n, 100 * f / n }' \
    "$work/trace.log"
# 3. Peak stack use of the hub's paths (stack painting; the firmware
# library's own boot, command and sample code on each kind's largest model).
# The budget: the F446's 128 KiB of SRAM less the hub's static RAM (29 KiB,
# scripts/firmware-size.sh) leaves 99 KiB; the stack is given 64 KiB of it
# (docs/firmware-cost.md, "Stack"), the rest is margin for the interrupt
# handlers' frames, which nest on top.
stack_budget=65536
status=0
timeout "$run_timeout_s" "${qemu[@]}" -kernel "$elf_dir/stack" >"$work/stack.txt" 2>&1 || status=$?
cat "$work/stack.txt"
[ "$status" -eq 0 ] || fail "stack exited with status $status"
grep -q '^stack: done$' "$work/stack.txt" || fail "no 'stack: done' line"
# The method's check: a frame holding a 16 KiB buffer measures the buffer
# plus the call's few words (at most 256 bytes more).
awk '/^verify: a frame holding/ { want = $5; got = $8; seen = 1;
        if (got < want || got > want + 256) { print "stack verify off: " $0; bad = 1 } }
     END { exit (bad || !seen) }' "$work/stack.txt" || fail "stack-painting check failed"
for kind in tf bp linear pcr arma fbank; do
    grep -q "^| $kind | [0-9]" "$work/stack.txt" || fail "no '$kind' stack line"
done
boot=$(sed -n 's/^boot without a model: \([0-9]*\) bytes$/\1/p' "$work/stack.txt")
[ -n "$boot" ] || fail "no boot stack line"
[ "$boot" -le "$stack_budget" ] || fail "boot's stack use $boot is over $stack_budget bytes"
# A cell is a byte count, or ">= N" when a path used all the paint: that
# fails too (a number is required, not only one under the budget).
awk -F'|' -v budget="$stack_budget" '/^\| (tf|bp|linear|pcr|arma|fbank) \| / {
        over = (NF != 7)
        for (i = 3; i <= 6; i++) if ($i !~ /^ *[0-9]+ *$/ || $i + 0 > budget) over = 1
        if (over) { print "over the stack budget: " $0; bad = 1 }
    } END { exit bad }' "$work/stack.txt" || fail "a path's stack use is over $stack_budget bytes"
echo "qemu-bench: OK"
