#!/usr/bin/env bash
# Sizes of the firmware images (release, fat LTO), as `llvm-size` prints them, with the flash and
# static-RAM totals: the STM32F411CE board (default features, and with `multi-talker`), the
# STM32F446RE board (`board-f446`) and the emulated board (`board-mps2`). Builds them first. Then
# measures the stack: the emulated board runs the application twice on a 12 s scene of an imperfect
# array (`host-sim scene`, 16 kHz) with an estimate store file, as the STM32 boards always have one:
# a cold boot that learns and saves a record, then a warm boot that starts from it. Each run reports
# its stack high-water mark (the stack is painted at boot and scanned at the end,
# `boards/mps2.rs`, `stack_watermark`); the larger is added to each board's static RAM against the 48 KB
# budget (the boards share the application and the core; their own start-up code differs).
# Fails when a default image (`firmware`, `firmware-f446`) is over a budget: flash 128 KB, static RAM
# + stack 48 KB.
#
# Usage: scripts/board-sizes.sh [--readme]
#   --readme  also writes the table into firmware/README.md, between its markers
#             "<!-- board-sizes.sh: begin -->" and "<!-- board-sizes.sh: end -->".
set -euo pipefail
cd "$(dirname "$0")/.."
TARGET=thumbv7em-none-eabihf
OUT=${CARGO_TARGET_DIR:-target}/$TARGET/release
SIZE="$(rustc --print sysroot)/lib/rustlib/x86_64-unknown-linux-gnu/bin/llvm-size"
README=firmware/README.md

# The F411 image with the multi-talker tracks, kept beside the default one.
cargo build -q -p firmware --release --target $TARGET --features multi-talker
cp "$OUT/firmware" "$OUT/firmware-multi-talker"
cargo build -q -p firmware --release --target $TARGET
cargo build -q -p firmware --release --target $TARGET --no-default-features --features board-f446
cargo build -q -p firmware --release --target $TARGET --no-default-features --features board-mps2

# The stack high-water mark of the application on the emulated board.
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo run -q --release -p host-sim -- scene --synth 12 --track 0:30,4:150,8:-90 --snr 3 --seed 4 \
  --capsule-gain-db 1,-1,0.5 --capsule-beta 0.45,0.57,0.5 --rate 16000 \
  --out "$work/scene.wav" >/dev/null 2>&1
stack=0
for boot in cold warm; do
  s=$(timeout 300 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -icount shift=4,sleep=off \
    -display none -monitor none -serial null \
    -semihosting-config "enable=on,target=native,arg=firmware-mps2,arg=$work/scene.wav,arg=$work/store" \
    -kernel "$OUT/firmware-mps2" 2>&1 | awk '/stack high-water mark/ {print $5}')
  [ -n "$s" ] || { echo "board-sizes.sh: no stack report from the emulated board ($boot boot)" >&2; exit 1; }
  [ "$s" -gt "$stack" ] && stack=$s
done

table=$(
  echo "| image (board) | text | data | bss | flash (text + data) | static RAM (data + bss) | static RAM + stack |"
  echo "|---|---:|---:|---:|---:|---:|---:|"
  for pair in "firmware:STM32F411CE" "firmware-multi-talker:STM32F411CE, --features multi-talker" \
    "firmware-f446:STM32F446RE" "firmware-mps2:QEMU mps2-an386"; do
    bin=${pair%%:*}
    board=${pair#*:}
    "$SIZE" "$OUT/$bin" | awk -v bin="$bin" -v board="$board" -v stack="$stack" 'NR == 2 {
      printf "| `%s` (%s) | %d B | %d B | %d B | %.1f KB | %.1f KB | %.1f KB |\n", bin, board, $1,
        $2, $3, ($1 + $2) / 1024, ($2 + $3) / 1024, ($2 + $3 + stack) / 1024 }'
  done
  echo
  echo "Stack: a high-water mark of $stack B, measured on the emulated board (the application on a 12 s"
  echo "scene, a cold and a warm boot with an estimate store; the stack painted at boot, before the"
  echo "localizer is built, and scanned at the end)."
  echo "Budgets of the default images: flash ≤ 128 KB, static RAM + stack ≤ 48 KB (the F411 has 512 KB"
  echo "of flash and 128 KB of RAM)."
  echo
  echo "Written by \`scripts/board-sizes.sh --readme\` at $(git rev-parse --short HEAD)$(git diff --quiet -- firmware || echo ' with local changes to firmware/')."
)
echo "$table"

over=0
for bin in firmware firmware-f446; do
  read -r text data bss _ < <("$SIZE" "$OUT/$bin" | awk 'NR == 2')
  if [ $((text + data)) -gt $((128 * 1024)) ] || [ $((data + bss + stack)) -gt $((48 * 1024)) ]; then
    echo "board-sizes.sh: $bin is over budget: flash $((text + data)) B (≤ 131072), static RAM + stack $((data + bss + stack)) B (≤ 49152)" >&2
    over=1
  fi
done

if [ "${1:-}" = "--readme" ]; then
  echo "$table" | scripts/write-section.sh "$README" board-sizes.sh
fi
[ "$over" = 0 ]
