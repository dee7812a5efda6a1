#!/usr/bin/env python3
"""Static bound on the hub's stack, from the linked image's machine code.

Painting (firmware/qemu-bench, `scripts/qemu-bench.sh`) measures the paths
the bench drives; this reads every path the code has. From `llvm-objdump -d`
of the firmware ELF:

  frame(f)   bytes f reserves: 4 per register of each `push`, 8 per double
             register of each `vpush`, each `sub sp, #N` and each
             `str rX, [sp, #-N]!` (all of them, so a function that reserves
             in two branches counts both: an upper bound);
  calls(f)   direct `bl`/`blx` targets, and branches (`b`, `b.w`, `bCC`) to
             another function's entry (tail calls; the caller's frame is
             counted too, an upper bound);
  depth(f)   frame(f) + the deepest of depth(callee).

A call through a register (`blx rN`, `bx rN`) cannot be followed: the
script lists each such site the roots reach, and the bound holds only if
they do not go deeper (on this firmware: the RTIC executor's waker vtables
and defmt's RTT writer). A cycle in the call graph (recursion) has no bound;
it is reported and the script fails.

The hub's worst case stacks one context per priority level (Cortex-M
preemption nests by level; tasks of one level never preempt each other),
each preemption adding its exception frame (104 B: the FPU's extended
frame, the largest):

  boot     Reset -> main -> init (interrupts masked): alone;
  running  Reset -> main -> idle, plus the deepest handler at each level:
           priority 1 (UART4: command, store, emit), 2 (UART5: sample),
           3 (USART2, CAN1_RX0), SysTick (the monotonic, priority 0, the
           highest) and any other vector bound (listed with level "other",
           counted as one more level). The levels are read from the RTIC
           app, firmware/src/main.rs (`rtic_levels`), so a task moved to
           another priority moves in the bound too.

usage: scripts/stack-bound.py ELF [--budget BYTES] [--json]
Fails (exit 1) on a cycle, an unknown instruction touching sp, or a bound
above --budget (default 65536, docs/design-card.md).
"""
import argparse
import functools
import json
import os
import re
import shutil
import subprocess
import sys

EXCEPTION_FRAME = 104
# The RTIC app whose priorities nest (read by `rtic_levels`).
APP = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "firmware", "src", "main.rs")
# Vector entries that do not run on the hub's paths (the core stops, the
# watchdog resets it).
NOT_RUN = {"HardFault", "HardFault_", "HardFaultTrampoline", "DefaultHandler",
           "DefaultHandler_", "NonMaskableInt", "MemoryManagement", "BusFault",
           "UsageFault", "SecureFault", "SVCall", "DebugMonitor", "PendSV",
           "Reset"}


@functools.lru_cache(maxsize=None)
def tool(name):
    """An LLVM tool from the Rust toolchain's llvm-tools, else on PATH."""
    sysroot = subprocess.run(["rustc", "--print", "sysroot"], capture_output=True,
                             text=True).stdout.strip()
    for root, _, files in os.walk(os.path.join(sysroot, "lib", "rustlib")):
        if name in files:
            return os.path.join(root, name)
    found = shutil.which(name)
    if not found:
        sys.exit(f"stack-bound: {name} not found (rustup component add llvm-tools)")
    return found


def functions(elf):
    """Function symbols: {address: (name, size)}."""
    out = subprocess.run([tool("llvm-nm"), "-S", "-n", "--defined-only", elf],
                         check=True, capture_output=True, text=True).stdout
    funcs = {}
    for line in out.splitlines():
        p = line.split()
        if len(p) == 4 and p[2] in "Tt" and int(p[1], 16) > 0:
            funcs.setdefault(int(p[0], 16), (p[3], int(p[1], 16)))
    return funcs


def owner_of(funcs):
    starts = sorted(funcs)

    def owner(addr):
        lo, hi = 0, len(starts)
        while lo < hi:
            mid = (lo + hi) // 2
            if starts[mid] <= addr:
                lo = mid + 1
            else:
                hi = mid
        if lo == 0:
            return None
        s = starts[lo - 1]
        return s if addr < s + funcs[s][1] else None
    return owner


def regs(text):
    """Registers in a list like {r4, r5, r7, lr} or {d8-d15}."""
    n = 0
    for part in text.strip("{} ").split(","):
        part = part.strip()
        m = re.match(r"([a-z]+)(\d+)-[a-z]+(\d+)$", part)
        n += int(m.group(3)) - int(m.group(2)) + 1 if m else 1
    return n


INSN = re.compile(r"^\s*([0-9a-f]+):\s+(\S+)\s*(.*)$")


def scan(elf, funcs):
    """Per function: frame bytes, direct callees, indirect call sites."""
    owner = owner_of(funcs)
    dis = subprocess.run([tool("llvm-objdump"), "-d", "--no-show-raw-insn", elf],
                         check=True, capture_output=True, text=True).stdout
    frame = {a: 0 for a in funcs}
    calls = {a: set() for a in funcs}
    indirect = {a: [] for a in funcs}
    odd, low, pairs = [], {}, set()
    for line in dis.splitlines():
        m = INSN.match(line)
        if not m:
            continue
        addr, mn, ops = int(m.group(1), 16), m.group(2), m.group(3).split("@")[0].strip()
        f = owner(addr)
        if f is None:
            continue
        base = mn.split(".")[0]
        mw = re.match(r"(r\d+|ip|lr), #(0x[0-9a-f]+|\d+)$", ops)
        if base == "movw" and mw:
            low[mw.group(1)] = int(mw.group(2), 0)
        elif base == "movt" and mw and mw.group(1) in low:
            pairs.add(((int(mw.group(2), 0) << 16) | low.pop(mw.group(1))) & ~1)
        if base == "push":
            frame[f] += 4 * regs(ops)
        elif base == "vpush":
            frame[f] += (8 if "d" in ops else 4) * regs(ops)
        elif re.match(r"sub(w)?$", base) and re.match(r"sp, (sp, )?#", ops):
            frame[f] += int(ops.split("#")[1], 0)
        elif re.match(r"str\S*$", base) and re.search(r"\[sp, #-\d+\]!", ops):
            frame[f] += int(re.search(r"#-(\d+)", ops).group(1))
        elif re.match(r"v?(stmdb|stmfd)$", base) and ops.startswith("sp!"):
            rl = ops.split(",", 1)[1]
            frame[f] += (8 if "d" in rl else 4) * regs(rl)
        elif re.match(r"v?(ldm|ldmia|ldmfd|stm|stmia)$", base) and ops.startswith("sp"):
            pass  # reads or writes the frame (ldm sp!: gives stack back)
        elif ops.startswith("sp,") or ops == "sp":
            # Giving stack back (add sp, #N; sp restored from the frame
            # pointer r7) is fine; any other write to sp is not counted.
            restore = re.match(r"(mov|sub|subw)$", base) and re.match(r"sp, r7(, #\d+)?$", ops)
            if not (re.match(r"add(w)?$", base) and re.match(r"sp, (sp, )?#", ops)) and not restore:
                odd.append((funcs[f][0], line.strip()))
        elif base in ("blx", "bx") and re.match(r"r\d+$|r1[0-2]$|ip$", ops):
            indirect[f].append(line.strip())
        elif re.match(r"b(l|lx)?(eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le)?$", base) \
                and re.match(r"0x[0-9a-f]+|[0-9a-f]+ <", ops):
            target = int(re.match(r"(?:0x)?([0-9a-f]+)", ops).group(1), 16)
            t = owner(target)
            if t is not None and (t != f or base.startswith("bl")) and target == t:
                calls[f].add(t)
    return frame, calls, indirect, odd, pairs


def section_words(elf, section):
    """The section's contents as little-endian 32-bit words from its start
    (the sections read here are word-aligned)."""
    out = subprocess.run([tool("llvm-objdump"), "-s", "-j", section, elf],
                         check=True, capture_output=True, text=True).stdout
    data = bytearray()
    for line in out.splitlines():
        m = re.match(r"^\s*[0-9a-f]+((?: [0-9a-f]{2,8}){1,4})  ", line)
        if m:
            data += bytes.fromhex("".join(m.group(1).split()))
    return [int.from_bytes(data[i:i + 4], "little") for i in range(0, len(data) - 3, 4)]


def address_taken(elf, funcs, dis_pairs):
    """Functions whose address the image holds (vtables and function
    pointers in .rodata/.data, literal pools in .text, movw/movt pairs):
    what a call through a register can reach."""
    taken = set()
    for section in (".text", ".rodata", ".data"):
        for w in section_words(elf, section):
            if w & 1 and (w & ~1) in funcs:
                taken.add(w & ~1)
    taken |= {a for a in dis_pairs if a in funcs}
    return taken


def vectors(elf, funcs):
    """Handlers of the vector table: {name: address}."""
    words = section_words(elf, ".vector_table")
    handlers = {}
    for w in words[1:]:  # words[0]: the initial stack pointer
        a = w & ~1
        if a in funcs:
            handlers[funcs[a][0]] = a
    return handlers


# A panic ends the hub's work (the handler halts, the watchdog resets it):
# what runs past its entry is not followed (it recurses: a panic while
# formatting a panic).
PANIC = re.compile(r"core9panicking|rust_begin_unwind|panic_fmt|panic_probe|defmt\w*panic")


INDIRECT = "(a call through a register: the deepest address-taken function)"


def deepest(frame, calls, funcs, indirect=None, reach_bytes=0):
    """depth(f) and the path, by memoised search; a cycle raises. A
    function with a call through a register counts `reach_bytes` for it."""
    memo, on = {}, []

    def go(f):
        if f in memo:
            return memo[f]
        if f in on:
            cycle = on[on.index(f):] + [f]
            raise RecursionError(" -> ".join(demangle(funcs[g][0]) for g in cycle))
        on.append(f)
        best = (0, [])
        if indirect and indirect[f] and not PANIC.search(funcs[f][0]):
            best = (reach_bytes, [INDIRECT])
        for c in ([] if PANIC.search(funcs[f][0]) else sorted(calls[f])):
            d = go(c)
            if d[0] > best[0]:
                best = d
        on.pop()
        memo[f] = (frame[f] + best[0], [f] + best[1])
        return memo[f]
    return go


def reach(calls, root):
    seen, todo = set(), [root]
    while todo:
        f = todo.pop()
        if f not in seen:
            seen.add(f)
            todo.extend(calls[f])
    return seen


def demangle(name):
    m = re.match(r"_ZN(.*)17h[0-9a-f]{16}E$", name)
    if not m:
        return name
    parts, s = [], m.group(1)
    while s and s[0].isdigit():
        n = int(re.match(r"\d+", s).group(0))
        s = s[len(str(n)):]
        parts.append(s[:n])
        s = s[n:]
    return "::".join(parts).replace("$LT$", "<").replace("$GT$", ">").replace(
        "$u20$", " ").replace("$C$", ",").replace("$RF$", "&").replace("..", "::")


def steps(path, frame, funcs, reach_bytes):
    """A path as (bytes, name) per step."""
    return [(reach_bytes, f) if f == INDIRECT else (frame[f], demangle(funcs[f][0]))
            for f in path]


def indirect_cost(frame, calls, funcs, indirect, targets):
    """What one call through a register costs at most: the deepest
    address-taken function, itself allowed one more such call to the
    deepest of them."""
    direct = deepest(frame, calls, funcs)
    leaf = max((direct(t)[0] for t in targets), default=0)
    once = deepest(frame, calls, funcs, indirect, leaf)
    return max((once(t)[0] for t in targets), default=0)


def rtic_levels(main_rs):
    """{vector: priority level} of the RTIC app in `main_rs`: each hardware
    task's `binds` at its `priority`, and the dispatchers of the software
    tasks' levels as rtic-macros assigns them (the levels from the highest
    down take the `dispatchers` list from its end); SysTick, which
    rtic-monotonics leaves at hardware priority 0 (the highest), one level
    above every task. One `#[task(...)]` attribute per line, as rustfmt
    leaves them."""
    with open(main_rs) as f:
        src = f.read()
    app = re.search(r"#\[rtic::app\(.*dispatchers\s*=\s*\[([^\]]*)\]", src)
    if not app:
        sys.exit(f"stack-bound: no `#[rtic::app(.., dispatchers = [..])]` in {main_rs}")
    dispatchers = [d.strip() for d in app.group(1).split(",") if d.strip()]
    levels, soft = {}, set()
    for line in src.splitlines():
        line = line.strip()
        if not line.startswith("#[task("):
            continue
        prio = re.search(r"\bpriority\s*=\s*(\d+)", line)
        if not prio:
            sys.exit(f"stack-bound: a task without a priority in {main_rs}: {line}")
        binds = re.search(r"\bbinds\s*=\s*(\w+)", line)
        if binds:
            levels[binds.group(1)] = int(prio.group(1))
        else:
            soft.add(int(prio.group(1)))
    soft = sorted(p for p in soft if p > 0)
    if len(soft) > len(dispatchers):
        sys.exit(f"stack-bound: {len(soft)} software priority levels, {len(dispatchers)} dispatchers")
    for p in reversed(soft):
        levels[dispatchers.pop()] = p
    if not levels:
        sys.exit(f"stack-bound: no tasks found in {main_rs}")
    levels["SysTick"] = max(levels.values()) + 1
    return levels


def nested(handlers, depth, frame, by_name, levels_of):
    """Boot alone, and what stays under the handlers (Reset's and main's
    frames, an idle task's path where there is one) with the deepest
    handler of each priority level on top."""
    boot = depth(handlers["Reset"])
    idle = [a for n, a in by_name.items() if re.search(r"3app4idle", n)]
    idle_path = max((depth(a) for a in idle), default=(0, []))
    base = frame[handlers["Reset"]] + frame.get(by_name.get("main"), 0) + idle_path[0]
    levels = {}
    for n, a in handlers.items():
        if n in NOT_RUN:
            continue
        d = depth(a)
        lv = levels_of.get(n, "other")
        if lv not in levels or d[0] > levels[lv][1][0]:
            levels[lv] = (n, d)
    running = base + sum(d[0] + EXCEPTION_FRAME for _, d in levels.values())
    return boot, base, levels, running


def analyse(elf, budget, app=APP):
    """The bound and how it is made up, as the report prints it."""
    funcs = functions(elf)
    frame, calls, indirect, odd, pairs = scan(elf, funcs)
    handlers = vectors(elf, funcs)
    by_name = {n: a for a, (n, _) in funcs.items()}
    # Calls through a register may reach any address-taken function but a
    # vector's handler (the hardware calls those, counted by level).
    targets = address_taken(elf, funcs, pairs) - set(handlers.values())
    try:
        reach_bytes = indirect_cost(frame, calls, funcs, indirect, targets)
        depth = deepest(frame, calls, funcs, indirect, reach_bytes)
        boot, base, levels, running = nested(handlers, depth, frame, by_name, rtic_levels(app))
    except RecursionError as e:
        sys.exit(f"stack-bound: recursion ({e}): no static bound")
    reached = set()
    for n, a in handlers.items():
        if n == "Reset" or n not in NOT_RUN:
            reached |= reach(calls, a)
    sites = [(funcs[f][0], s) for f in sorted(reached) for s in indirect[f]]
    path = functools.partial(steps, frame=frame, funcs=funcs, reach_bytes=reach_bytes)
    return {
        "boot_bytes": boot[0],
        "idle_bytes": base,
        "levels": {str(lv): {"root": n, "bytes": d[0], "path": path(d[1])}
                   for lv, (n, d) in sorted(levels.items(), key=lambda x: str(x[0]))},
        "exception_frame_bytes": EXCEPTION_FRAME,
        "running_bytes": running,
        "bound_bytes": max(boot[0], running),
        "budget_bytes": budget,
        "boot_path": path(boot[1]),
        "call_through_register_bytes": reach_bytes,
        "address_taken_functions": len(targets),
        "indirect_call_sites": [f"{demangle(n)}: {s}" for n, s in sites],
        "unrecognised_sp_writes": [f"{demangle(n)}: {s}" for n, s in odd],
    }


def print_text(r):
    print(f"boot (Reset -> main -> init, alone): {r['boot_bytes']} B")
    for b, name in r["boot_path"]:
        print(f"    {b:>7} {name[:100]}")
    print(f"under the handlers (Reset, main, idle): {r['idle_bytes']} B")
    for lv, v in r["levels"].items():
        print(f"level {lv}: {v['root']} {v['bytes']} B "
              f"(+{r['exception_frame_bytes']} B exception frame)")
        for b, name in v["path"]:
            print(f"    {b:>7} {name[:100]}")
    print(f"running (idle + every level preempting the one below): {r['running_bytes']} B")
    bound, budget = r["bound_bytes"], r["budget_bytes"]
    print(f"bound: {bound} B of the {budget} B budget ({100 * bound / budget:.1f} %)")
    print(f"calls through a register on these paths ({len(r['indirect_call_sites'])}), "
          f"each counted as {r['call_through_register_bytes']} B (the deepest of "
          f"{r['address_taken_functions']} address-taken functions):")
    for s in r["indirect_call_sites"]:
        print(f"    {s[:140]}")
    for s in r["unrecognised_sp_writes"]:
        print(f"unrecognised write to sp: {s}")


def main():
    ap = argparse.ArgumentParser(description="Static bound on the hub's stack.")
    ap.add_argument("elf", help="the firmware ELF (scripts/firmware-size.sh builds it)")
    ap.add_argument("--budget", type=int, default=65536, help="bytes (docs/design-card.md)")
    ap.add_argument("--json", action="store_true", help="the report as JSON")
    a = ap.parse_args()
    r = analyse(a.elf, a.budget)
    if a.json:
        print(json.dumps(r, indent=1))
    else:
        print_text(r)
    if r["unrecognised_sp_writes"]:
        sys.exit("stack-bound: an instruction writes sp in a way this script does not count")
    if r["bound_bytes"] > a.budget:
        sys.exit(f"stack-bound: {r['bound_bytes']} B over the {a.budget} B budget")


if __name__ == "__main__":
    main()
