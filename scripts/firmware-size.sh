#!/usr/bin/env bash
# Build the firmware for the STM32F446 twice and report what the model path costs.
#
#   scripts/firmware-size.sh            # human-readable report + a machine line
#   scripts/firmware-size.sh | tail -1  # flash_bytes=N ram_bytes=M (default build)
#
# Builds (`--profile firmware`: LTO, one codegen unit, opt-level "s"; root Cargo.toml):
#   baseline    --no-default-features: the RTIC shell without model-core
#               (offsets always zero)
#   with model  default features: decodes slot A at boot and steps the model
#               every sample. One firmware runs every model kind, so this is
#               the shared code cost of decode + validate + step of all kinds.
# The default build is built last, so the ELF under
# target/thumbv7em-none-eabihf/firmware/firmware is the one to flash; the
# baseline ELF is kept next to it as firmware-baseline.
#
# Then the largest model-core/libm symbols of the default build (llvm-nm) and
# the model path's code by source file (line table of `llvm-objdump -d -l`):
# LTO inlines decode/validate/step into `init` and the `sample` task, so nm
# alone does not show most of it.
#
# Tools, first found wins: arm-none-eabi-size, else llvm-size / llvm-nm /
# llvm-objdump from the Rust toolchain's llvm-tools component, else on PATH.
# CI: `rustup component add llvm-tools` (the script tries it itself if no size
# tool is found). `apt-get install -y binutils-arm-none-eabi` works for size.
#
# flash = text + data (code, rodata, vector table, .data load image)
# ram   = data + bss  (static RAM incl. .uninit, e.g. the defmt RTT buffer;
#                      the stack is not counted: its region is checked
#                      below, its use by scripts/qemu-bench.sh)
# Honours CARGO_TARGET_DIR; extra arguments go to both `cargo build`s.
set -euo pipefail

TARGET=thumbv7em-none-eabihf
PROFILE=firmware
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target}"
case "$TARGET_DIR" in /*) ;; *) TARGET_DIR="$ROOT/$TARGET_DIR" ;; esac
ELF="$TARGET_DIR/$TARGET/$PROFILE/firmware"
BASE_ELF="$ELF-baseline"
# Region sizes from memory.x (FLASH = sectors 0-4, RAM = SRAM1+SRAM2).
FLASH_REGION=$((128 * 1024))
RAM_REGION=$((128 * 1024))

cd "$ROOT"
rustup target add "$TARGET" >/dev/null 2>&1 || true

# An LLVM tool from the toolchain's llvm-tools component, else from PATH.
llvm_tool() {
  local found
  found="$(compgen -G "$(rustc --print sysroot)/lib/rustlib/*/bin/$1" | head -n1 || true)"
  if [ -z "$found" ] && command -v "$1" >/dev/null 2>&1; then
    found="$(command -v "$1")"
  fi
  printf '%s' "$found"
}

if command -v arm-none-eabi-size >/dev/null 2>&1; then
  SIZE=arm-none-eabi-size
else
  SIZE="$(llvm_tool llvm-size)"
  if [ -z "$SIZE" ] && command -v rustup >/dev/null 2>&1 && rustup component add llvm-tools >&2; then
    SIZE="$(llvm_tool llvm-size)"
  fi
fi
if [ -z "$SIZE" ]; then
  echo "error: no size tool; run 'rustup component add llvm-tools'" >&2
  exit 1
fi
NM="$(llvm_tool llvm-nm)"
OBJDUMP="$(llvm_tool llvm-objdump)"

# "flash ram text data bss" of an ELF (Berkeley format: header, then
# "text data bss dec hex filename").
measure() {
  local text data bss
  read -r text data bss _ < <("$SIZE" -B "$1" | awk '$1 ~ /^[0-9]+$/ { line = $0 } END { print line }')
  if [ -z "${bss:-}" ]; then
    echo "error: could not parse output of $SIZE -B $1" >&2
    exit 1
  fi
  echo "$((text + data)) $((data + bss)) $text $data $bss"
}

build() {
  cargo build -p firmware --target "$TARGET" --profile "$PROFILE" "$@" >&2
}

build --no-default-features "$@"
cp "$ELF" "$BASE_ELF"
read -r base_flash base_ram base_text base_data base_bss < <(measure "$BASE_ELF")
build "$@"
read -r flash ram text data bss < <(measure "$ELF")

pct() { printf '%d.%d%%' $(($1 * 100 / $2)) $(($1 * 1000 / $2 % 10)); }
row() { printf '  %-22s %8s %8s %8s %8s %8s\n' "$@"; }

echo "firmware size ($TARGET, profile $PROFILE) via ${SIZE##*/}"
echo "  elf: $ELF (baseline: ${BASE_ELF##*/})"
row "build" "flash" "ram" "text" "data" "bss"
row "baseline (no model)" "$base_flash" "$base_ram" "$base_text" "$base_data" "$base_bss"
row "with model (default)" "$flash" "$ram" "$text" "$data" "$bss"
row "model path costs" "+$((flash - base_flash))" "+$((ram - base_ram))" \
  "+$((text - base_text))" "+$((data - base_data))" "+$((bss - base_bss))"
echo "  default build: flash $(pct "$flash" "$FLASH_REGION") of the $((FLASH_REGION / 1024)) KiB FLASH region," \
  "ram $(pct "$ram" "$RAM_REGION") of $((RAM_REGION / 1024)) KiB (static; the stack: scripts/qemu-bench.sh)"

# The stack region of the default build. flip-link (.cargo/config.toml) puts
# the stack below the statics, from `_stack_start` down to the start of RAM
# (`_stack_end`), so an overflow faults instead of overwriting a static; the
# region must hold the stack budget scripts/qemu-bench.sh checks the paths
# against (docs/firmware-cost.md, "Stack").
STACK_BUDGET=$((64 * 1024))
RAM_ORIGIN=$((0x20000000))
if [ -n "$NM" ]; then
  sym() {
    local v
    v="$("$NM" "$ELF" | awk -v s="$1" '$3 == s { print $1 }')"
    if [ -z "$v" ]; then
      echo "firmware-size: no symbol $1 in $ELF" >&2
      exit 1
    fi
    echo $((16#$v))
  }
  stack_start=$(sym _stack_start)
  stack_end=$(sym _stack_end)
  statics=$(sym __sdata)
  stack_room=$((stack_start - stack_end))
  echo "  stack region: $(printf '0x%08x..0x%08x' "$stack_end" "$stack_start"), $stack_room bytes" \
    "(budget $STACK_BUDGET)"
  if [ "$stack_end" -ne "$RAM_ORIGIN" ] || [ "$stack_start" -gt "$statics" ]; then
    echo "firmware-size: the stack is not below the statics (is the linker flip-link?)" >&2
    exit 1
  fi
  if [ "$stack_room" -lt "$STACK_BUDGET" ]; then
    echo "firmware-size: $stack_room bytes of stack room, under the $STACK_BUDGET budget" >&2
    exit 1
  fi
else
  echo "  stack region: not checked (no llvm-nm: 'rustup component add llvm-tools')"
fi

# Legacy-mangled local symbols that llvm-nm leaves half-demangled
# (`_$LT$impl$u20$...`): undo the escapes and drop the hash.
tidy_symbols() {
  sed -E -e 's/\$LT\$/</g; s/\$GT\$/>/g; s/\$u20\$/ /g; s/\$C\$/,/g; s/\$RF\$/\&/g' \
    -e 's/\$BP\$/*/g; s/\$u5b\$/[/g; s/\$u5d\$/]/g; s/\$u3b\$/;/g; s/\$u7b\$/{/g; s/\$u7d\$/}/g' \
    -e 's/\.\./::/g; s/ _</ </; s/::h[0-9a-f]{16}$//'
}

echo
if [ -n "$NM" ]; then
  echo "largest model-core and libm symbols (default build; bytes, nm type, name)"
  "$NM" --print-size --size-sort --demangle "$ELF" | tidy_symbols \
    | { grep -E 'model_core::|libm::' || true; } | tail -n 15 | sort -r -k2,2 \
    | while read -r _ size type name; do
      printf '  %6d %s %.110s\n' "$((16#$size))" "$type" "$name"
    done
else
  echo "(no llvm-nm: 'rustup component add llvm-tools' for the symbol list)"
fi

# Bytes of .text per source file from the line table: each instruction counts
# for the file its line-table row names. Inlined generic helpers (core::iter,
# slices, Result/Option) count for core, not for the model-core function that
# used them, so these are lower bounds.
if [ -n "$OBJDUMP" ]; then
  echo
  echo "model path code by source file (default build; line table, lower bounds)"
  "$OBJDUMP" -d -l --no-show-raw-insn "$ELF" | awk '
    function hex(s,   i, n) {
      n = 0; s = tolower(s)
      for (i = 1; i <= length(s); i++) n = n * 16 + index("0123456789abcdef", substr(s, i, 1)) - 1
      return n
    }
    /^[0-9a-f]+ <.*>:$/ { have = 0; next }
    /^; \/.*:[0-9]+$/ { cur = $2; sub(/:[0-9]+$/, "", cur); next }
    /^ *[0-9a-f]+:/ {
      a = $1; sub(/:$/, "", a); addr = hex(a)
      if (have && addr > prev) bytes[file] += addr - prev
      prev = addr; file = cur; have = 1
    }
    END {
      for (f in bytes) {
        g = ""
        if (match(f, /model-core\/src\/[a-z_]+\.rs$/)) g = "model-core " substr(f, RSTART + 15)
        else if (f ~ /compiler-builtins\/src\/float\//) g = "compiler-builtins float (soft f64)"
        else if (match(f, /\/(libm|postcard|heapless|serde_core|serde)-[0-9][^\/]*\//)) {
          g = substr(f, RSTART + 1, RLENGTH - 2); sub(/-[0-9][^-]*$/, "", g)
        }
        if (g != "") sum[g] += bytes[f]
      }
      for (g in sum) printf "%d %s\n", sum[g], g
    }' | sort -rn | while read -r n what; do printf '  %6d %s\n' "$n" "$what"; done
fi

echo "flash_bytes=$flash ram_bytes=$ram"
