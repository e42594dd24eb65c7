#!/usr/bin/env bash
# Reproduces the numbers of docs/calibration.md: simulated sweep recordings of an imperfect and of an
# ideal CMA1 (anechoic and in a room), calibration, and evaluation of ideal vs measured tables.
# Usage: docs/calibration_experiment.sh WORKDIR RIR.wav   (RIR: first-order AmbiX room response)
set -euo pipefail
W=${1:?workdir}; RIR=${2:?room response}
HS=${HS:-target/debug/host-sim}
IMPERFECT="--capsule-gain-db 1,-1,0.5 --capsule-beta 0.45,0.55,0.5 --beta-drift 0.15 --drift-corner 400"
mkdir -p "$W"
$HS sweep --out "$W/sweep.wav" --f1 50 --f2 20000 --seconds 3 --rate 48000

record() { # array-name room(yes/no) flags...
  local name=$1 room=$2; shift 2
  local d="$W/rec_${name}_${room}"; mkdir -p "$d"; echo "file,azimuth_deg" > "$d/calibration.csv"
  local rir=(); [ "$room" = room ] && rir=(--rir "$RIR" --rir-length 0.5)
  for q in $(seq 0 71); do
    az=$((q * 5))
    $HS scene --out "$d/az$az.wav" --source "$W/sweep.wav" --rate 48000 --azimuth $az --lead-in 0.05 \
      --snr 40 --seed $((q + 1)) --format float "${rir[@]}" "$@"
    echo "az$az.wav,$az" >> "$d/calibration.csv"
  done
  $HS calibrate --dir "$d" --sweep "$W/sweep.wav" --f1 50 --f2 20000 --out "$W/table_${name}_${room}.cmat" \
    --plot "$W/table_${name}_${room}.png"
}

scenes() { # array-name room flags...
  local name=$1 room=$2; shift 2
  local d="$W/eval_${name}"; mkdir -p "$d"
  local rir=(); [ "$room" = room ] && rir=(--rir "$RIR")
  local i=0
  for snr in 0 10; do
    for az in -165 -130 -100 -70 -35 -5 20 55 80 115 145 175; do
      i=$((i + 1))
      $HS scene --out "$d/${room}_${snr}dB_$i.wav" --synth 3 --rate 16000 --azimuth $az --snr $snr \
        --seed $((i * 7 + ${#room})) --manifest "$d/manifest.csv" --set "${room}_${snr}dB" "${rir[@]}" "$@"
    done
  done
}

record imperfect anechoic $IMPERFECT
record imperfect room $IMPERFECT
record ideal anechoic
record ideal room
for room in anechoic room; do
  scenes imperfect $room $IMPERFECT
  scenes ideal $room
done
