#!/usr/bin/env bash
# Flash cost of a measured reference table embedded in the firmware (`CMA_TABLE`): builds the F411
# image (release, fat LTO) without a table and with tables of two sizes — the default calibration
# grid (5°, rows every 93.75 Hz) and the thesis's (15°, rows every 187.5 Hz) — each with the rows of
# both feature kinds and with one kind's (`CMA_TABLE_FEATURES`), and prints `llvm-size`'s text and
# the embedded table's bytes (the `MEASURED_*` statics, from `llvm-nm`). The tables are computed by
# `host-sim calibrate --selfcal-in` from the estimate of a generated scene: their size depends only
# on the grid. Rebuilds the default image at the end. Fails (after printing) when the 15° table with
# the active rows only, which docs/calibration.md says fits, is over the 128 KiB budget.
#
# Usage: scripts/table-sizes.sh [--doc]
#   --doc  also writes the table into docs/calibration.md, between its markers
#          "<!-- table-sizes.sh: begin -->" and "<!-- table-sizes.sh: end -->".
set -euo pipefail
cd "$(dirname "$0")/.."
TARGET=thumbv7em-none-eabihf
OUT=${CARGO_TARGET_DIR:-target}/$TARGET/release
HS=${CARGO_TARGET_DIR:-target}/release/host-sim
BIN="$(rustc --print sysroot)/lib/rustlib/x86_64-unknown-linux-gnu/bin"
DOC=docs/calibration.md
BUDGET=$((128 * 1024))

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build -q --release -p host-sim
"$HS" scene --synth 12 --track 0:30,4:150,8:-90 --snr 3 --seed 4 \
  --capsule-gain-db 1,-1,0.5 --capsule-beta 0.45,0.57,0.5 --rate 16000 \
  --out "$work/scene.wav" >/dev/null 2>&1
"$HS" locate "$work/scene.wav" --selfcal-out "$work/array.selfcal" >/dev/null 2>&1
"$HS" calibrate --selfcal-in "$work/array.selfcal" --out "$work/grid5.cmat" >/dev/null
"$HS" calibrate --selfcal-in "$work/array.selfcal" --grid 15 --freq-step 187.5 \
  --out "$work/grid15.cmat" >/dev/null

# row LABEL TABLE FEATURES: one line of the table for the image built with that table (none: "").
row() {
  CMA_TABLE=$2 CMA_TABLE_FEATURES=$3 cargo build -q -p firmware --release --target $TARGET
  local text table
  text=$("$BIN/llvm-size" "$OUT/firmware" | awk 'NR == 2 {print $1 + $2}')
  table=0
  while read -r _ size _; do
    table=$((table + 16#$size))
  done < <("$BIN/llvm-nm" -S -C "$OUT/firmware" | grep MEASURED_ || true)
  local fits=yes
  [ "$text" -le "$BUDGET" ] || fits=no
  [ "$fits" = yes ] || [ "$2$3" != "$work/grid15.cmatactive" ] || echo over >"$work/claim"
  printf '| %s | %s | %d | %d B | %s |\n' "$1" "${3:-–}" "$table" "$text" "$fits"
}

table=$(
  echo "| embedded table | \`CMA_TABLE_FEATURES\` | table bytes | flash (text + data) | within 128 KiB |"
  echo "|---|---|---:|---:|---|"
  row "none (the ideal model, as shipped)" "" ""
  row "72 azimuths (5°) × 42 rows (the default calibration)" "$work/grid5.cmat" both
  row "72 × 42" "$work/grid5.cmat" active
  row "24 azimuths (15°) × 21 rows (\`--grid 15 --freq-step 187.5\`)" "$work/grid15.cmat" both
  row "24 × 21" "$work/grid15.cmat" active
  row "24 × 21" "$work/grid15.cmat" magnitude
  echo
  echo "Written by \`scripts/table-sizes.sh --doc\` at $(git rev-parse --short HEAD)$(git diff --quiet -- firmware core-nostd || echo ' with local changes')."
)
# The default image again, for whatever runs next.
CMA_TABLE="" CMA_TABLE_FEATURES="" cargo build -q -p firmware --release --target $TARGET
echo "$table"

if [ -e "$work/claim" ]; then
  echo "table-sizes.sh: the 15° table with the active rows no longer fits 128 KiB" >&2
  exit 1
fi
if [ "${1:-}" = "--doc" ]; then
  echo "$table" | scripts/write-section.sh "$DOC" table-sizes.sh
fi
