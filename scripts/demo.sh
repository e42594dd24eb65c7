#!/usr/bin/env bash
# The main job on a fresh machine: synthesise example scenes from the bundled speech with
# `host-sim scene` (static talkers in diffuse noise, a jump, a circling talker), localize them with
# `host-sim locate`, and score them with `host-sim eval` (table + PNG plots in out/demo/plots).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/demo}
scripts/setup.sh   # idempotent: fonts for the plots and the tools the tests need
cargo build --release -p host-sim
HS=target/release/host-sim
rm -rf "$OUT"; mkdir -p "$OUT"
M="$OUT/manifest.csv"
SPEECH=host-sim/fixtures/cmu_arctic_us_aew_a0001.wav
FEMALE=host-sim/fixtures/cmu_arctic_us_axb_a0004.wav
i=0
for az in -135 -60 0 45 110 170; do
  i=$((i+1))
  for snr in 0 10; do
    $HS scene --source "$SPEECH" --azimuth "$az" --snr "$snr" --seed "$i" --out "$OUT/static_snr${snr}_az${az}.wav" --manifest "$M" --set "static-${snr}dB"
  done
done
# A jumping talker (48 kHz, PCM24, like the board's ADCs) and a circling one.
$HS scene --source "$FEMALE" --track "0:30,1.2:-100,2.4:150" --snr 5 --rate 48000 --format pcm24 --out "$OUT/jump_48k.wav" --manifest "$M" --set jump
$HS scene --synth 8 --rotate 30 --start-azimuth -120 --snr 10 --out "$OUT/moving.wav" --manifest "$M" --set moving
$HS locate "$OUT/jump_48k.wav" --csv "$OUT/jump_48k.csv"
echo "first estimates of $OUT/jump_48k.csv:"; head -5 "$OUT/jump_48k.csv"
echo
$HS eval "$OUT" --plots "$OUT/plots"
echo "plots: $OUT/plots/*.png"
