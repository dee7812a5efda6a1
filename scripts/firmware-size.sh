#!/usr/bin/env bash
# Build the release firmware for the STM32F446 and report its size.
#
#   scripts/firmware-size.sh            # human-readable report + a machine line
#   scripts/firmware-size.sh | tail -1  # flash_bytes=N ram_bytes=M
#
# Size tool, first found wins: arm-none-eabi-size, llvm-size from the Rust
# toolchain's llvm-tools component, llvm-size on PATH, `cargo size`
# (cargo-binutils). CI uses llvm-tools: `rustup component add llvm-tools`
# (no apt needed); the script installs it itself if no tool is found and
# rustup is available. `apt-get install -y binutils-arm-none-eabi` works too.
#
# flash = text + data (code, rodata, vector table, .data load image)
# ram   = data + bss  (static RAM incl. .uninit, e.g. the defmt RTT buffer;
#                      the stack is not counted)
# Honours CARGO_TARGET_DIR; extra arguments go to `cargo build`.
set -euo pipefail

TARGET=thumbv7em-none-eabihf
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target}"
case "$TARGET_DIR" in /*) ;; *) TARGET_DIR="$ROOT/$TARGET_DIR" ;; esac
ELF="$TARGET_DIR/$TARGET/release/firmware"
# Region sizes from memory.x (FLASH = sectors 0-5, RAM = SRAM1+SRAM2).
FLASH_REGION=$((256 * 1024))
RAM_REGION=$((128 * 1024))

cd "$ROOT"
rustup target add "$TARGET" >/dev/null 2>&1 || true
cargo build -p firmware --target "$TARGET" --release "$@" >&2

find_llvm_size() {
  local sysroot
  sysroot="$(rustc --print sysroot)"
  compgen -G "$sysroot/lib/rustlib/*/bin/llvm-size" | head -n1 || true
}

SIZE_CMD=()
if command -v arm-none-eabi-size >/dev/null 2>&1; then
  SIZE_CMD=(arm-none-eabi-size -B "$ELF")
elif tool="$(find_llvm_size)" && [ -n "$tool" ]; then
  SIZE_CMD=("$tool" -B "$ELF")
elif command -v llvm-size >/dev/null 2>&1; then
  SIZE_CMD=(llvm-size -B "$ELF")
elif cargo size --version >/dev/null 2>&1; then
  SIZE_CMD=(cargo size -q -p firmware --target "$TARGET" --release --)
elif command -v rustup >/dev/null 2>&1 && rustup component add llvm-tools >&2 \
  && tool="$(find_llvm_size)" && [ -n "$tool" ]; then
  SIZE_CMD=("$tool" -B "$ELF")
else
  echo "error: no size tool; run 'rustup component add llvm-tools'" >&2
  exit 1
fi

# Berkeley format: a header line, then "text data bss dec hex filename".
read -r text data bss _ < <("${SIZE_CMD[@]}" | awk '$1 ~ /^[0-9]+$/ { line = $0 } END { print line }')
if [ -z "${bss:-}" ]; then
  echo "error: could not parse output of ${SIZE_CMD[*]}" >&2
  exit 1
fi
flash=$((text + data))
ram=$((data + bss))

echo "firmware size ($TARGET, release) via ${SIZE_CMD[0]##*/}"
echo "  elf:   $ELF"
printf '  text %8d   data %8d   bss %8d\n' "$text" "$data" "$bss"
printf '  flash %7d B of %d B FLASH region (%d.%d%%)\n' "$flash" "$FLASH_REGION" \
  $((flash * 100 / FLASH_REGION)) $((flash * 1000 / FLASH_REGION % 10))
printf '  ram   %7d B of %d B RAM region (%d.%d%%, static; stack not counted)\n' "$ram" "$RAM_REGION" \
  $((ram * 100 / RAM_REGION)) $((ram * 1000 / RAM_REGION % 10))
echo "flash_bytes=$flash ram_bytes=$ram"
