#!/usr/bin/env bash
# Rebuilds every measured number of docs/calibration.md from host-sim runs and checks the page's
# claims: simulated sweep recordings of an imperfect and of an ideal CMA1 (anechoic and in a room),
# calibration, and evaluation of the ideal vs the measured tables for both feature kinds.
#
# Usage: docs/calibration_experiment.sh WORKDIR RIR.wav [--update-doc]
#   RIR: a first-order AmbiX room response (the page uses marco_p90deg_3m_FOA_ACN_SN3D.wav).
#   HS:  the host-sim binary (default target/release/host-sim, else target/debug/host-sim).
#   --update-doc: replace the generated section of docs/calibration.md (between the
#   "BEGIN/END calibration_experiment.sh" markers) with the new results.
# Exit status 1 (after printing every result) when a claim of the page no longer holds; each failed
# claim is printed as "CLAIM FAILED: …".
set -euo pipefail
W=${1:?workdir}; RIR=${2:?room response}; UPDATE=${3:-}
cd "$(dirname "$0")/.."
if [ -z "${HS:-}" ]; then
  HS=target/release/host-sim; [ -x "$HS" ] || HS=target/debug/host-sim
fi
IMPERFECT="--capsule-gain-db 1,-1,0.5 --capsule-beta 0.45,0.55,0.5 --beta-drift 0.15 --drift-corner 400"
SNRS="0 3 10"
mkdir -p "$W"
OUT="$W/results.md"; CLAIMS="$W/claims.txt"; : > "$OUT"; : > "$CLAIMS"; FAILED=0
$HS sweep --out "$W/sweep.wav" --f1 50 --f2 20000 --seconds 3 --rate 48000

# record ARRAY ROOM(anechoic|room) FLAGS…: 72 sweep recordings on a 5° grid (40 dB SNR diffuse
# noise) and their manifest; in the room the first-order response, rotated, truncated to 0.5 s.
record() {
  local name=$1 room=$2; shift 2
  local d="$W/rec_${name}_${room}"; mkdir -p "$d"; echo "file,azimuth_deg" > "$d/calibration.csv"
  local rir=(); [ "$room" = room ] && rir=(--rir "$RIR" --rir-length 0.5)
  for q in $(seq 0 71); do
    az=$((q * 5))
    $HS scene --out "$d/az$az.wav" --source "$W/sweep.wav" --rate 48000 --azimuth $az --lead-in 0.05 \
      --snr 40 --seed $((q + 1)) --format float "${rir[@]}" "$@"
    echo "az$az.wav,$az" >> "$d/calibration.csv"
  done
}

# calibrate NAME RECORDINGS-DIR EXTRA…: a table (the sweep's f1/f2 come from its WAV comment);
# keeps calibrate's report (crest factors, symmetry warning) in $W/NAME.log.
calibrate() {
  local name=$1 dir=$2; shift 2
  $HS calibrate --dir "$dir" --sweep "$W/sweep.wav" --out "$W/$name.cmat" --plot "$W/$name.png" "$@" \
    2> "$W/$name.log"
  cat "$W/$name.log" >&2
}

# scenes ARRAY FLAGS…: 12 azimuths × 0/3/10 dB diffuse noise × anechoic/room (full response), 3 s of
# synthetic speech at 16 kHz each, in one folder with sets ROOM_SNRdB.
scenes() {
  local name=$1; shift
  local d="$W/eval_${name}"; mkdir -p "$d"; rm -f "$d/manifest.csv"
  local i=0
  for room in anechoic room; do
    local rir=(); [ "$room" = room ] && rir=(--rir "$RIR")
    for snr in $SNRS; do
      for az in -165 -130 -100 -70 -35 -5 20 55 80 115 145 175; do
        i=$((i + 1))
        $HS scene --out "$d/${room}_${snr}dB_$i.wav" --synth 3 --rate 16000 --azimuth $az --snr $snr \
          --seed $((i * 7 + ${#room})) --manifest "$d/manifest.csv" --set "${room}_${snr}dB" \
          "${rir[@]}" "$@"
      done
    done
  done
}

# evaluate ARRAY TABLE(ideal|NAME) FEATURES → $W/m_ARRAY_TABLE_FEATURES.txt: "set frames ACC5 ACC10 MAE bias"
# The blind self-calibration (on by default; it corrects toward the ideal model and is off with a
# measured table anyway) is off throughout, so every row measures the table alone.
evaluate() {
  local array=$1 table=$2 features=$3
  local t=(); [ "$table" = ideal ] || t=(--table "$W/$table.cmat")
  $HS eval "$W/eval_$array" --features "$features" --selfcal off "${t[@]}" |
    awk 'NR > 1 && NF > 10 && $1 != "all" {print $1, $2, $4, $5, $8, $10}' \
    > "$W/m_${array}_${table}_${features}.txt"
}

# metric ARRAY TABLE FEATURES SET COLUMN(frames|acc5|acc10|mae|bias)
metric() {
  local col; case $5 in frames) col=2;; acc5) col=3;; acc10) col=4;; mae) col=5;; bias) col=6;; esac
  awk -v s="$4" -v c=$col '$1 == s {print $c}' "$W/m_$1_$2_$3.txt"
}

# claim TEXT AWK-CONDITION: records a checked claim of the page.
claim() {
  if awk "BEGIN {exit !($2)}"; then
    echo "claim holds: $1" >> "$CLAIMS"
  else
    echo "CLAIM FAILED: $1 ($2)" >> "$CLAIMS"; FAILED=1
  fi
}

record imperfect anechoic $IMPERFECT
record imperfect room $IMPERFECT
record ideal anechoic
record ideal room
calibrate imperfect_anechoic "$W/rec_imperfect_anechoic"
calibrate imperfect_room "$W/rec_imperfect_room"
calibrate ideal_anechoic "$W/rec_ideal_anechoic"
calibrate ideal_room "$W/rec_ideal_room"
# One third of the circle (0–115°) with --symmetry, on the imperfect array.
d="$W/rec_imperfect_anechoic_third"; mkdir -p "$d"
awk -F, 'NR == 1 || $2 < 120 {print}' "$W/rec_imperfect_anechoic/calibration.csv" |
  sed "s|^az|../rec_imperfect_anechoic/az|" > "$d/list.csv"
calibrate imperfect_symmetry "$d/list.csv" --symmetry
# The table small enough for the firmware's flash (scripts/table-sizes.sh): the thesis's 15° grid
# (every third recording) with rows every 187.5 Hz, anechoic, on the imperfect array.
d="$W/rec_imperfect_anechoic_15deg"; mkdir -p "$d"
awk -F, 'NR == 1 || $2 % 15 == 0 {print}' "$W/rec_imperfect_anechoic/calibration.csv" |
  sed "s|^az|../rec_imperfect_anechoic/az|" > "$d/list.csv"
calibrate imperfect_anechoic_15deg "$d/list.csv" --freq-step 187.5
# A 4 ms window in the room, and 83 rows (46.875 Hz apart) anechoic.
calibrate imperfect_room_4ms "$W/rec_imperfect_room" --window-ms 4
calibrate imperfect_anechoic_83rows "$W/rec_imperfect_anechoic" --freq-step 46.875
scenes imperfect $IMPERFECT
scenes ideal

TABLES_imperfect="ideal imperfect_anechoic imperfect_room imperfect_symmetry imperfect_room_4ms imperfect_anechoic_83rows imperfect_anechoic_15deg"
TABLES_ideal="ideal ideal_anechoic ideal_room"
for f in active magnitude; do
  for t in $TABLES_imperfect; do evaluate imperfect "$t" $f; done
  for t in $TABLES_ideal; do evaluate ideal "$t" $f; done
done

label() {
  case $1 in
    ideal) echo "ideal model";; *_anechoic) echo "measured, anechoic";; *_room) echo "measured, room";;
    imperfect_symmetry) echo "measured, anechoic, 0–115° + \`--symmetry\`";;
    imperfect_room_4ms) echo "measured, room, \`--window-ms 4\`";;
    imperfect_anechoic_83rows) echo "measured, anechoic, 83 rows";;
    imperfect_anechoic_15deg) echo "measured, anechoic, 15° grid × 21 rows";;
  esac
}

{
  echo "Lowest impulse-response crest factor per calibration (dB):"
  for n in imperfect_anechoic imperfect_room ideal_anechoic ideal_room; do
    printf -- '- %s: %s\n' "$n" "$(sed -n 's/.*lowest IR crest factor \([0-9.]*\) dB.*/\1/p' "$W/$n.log")"
  done
  echo
  for array in imperfect ideal; do
    tables=TABLES_$array
    echo "**Scenes of the $array array** (ACC in %, MAE and bias in °; each set 12 scenes of 3 s):"
    echo
    echo "| table | set | frames | active ACC5 | ACC10 | MAE | bias | magnitude ACC5 | ACC10 | MAE | bias |"
    echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    for t in ${!tables}; do
      while read -r set frames _; do
        a=($(awk -v s="$set" '$1 == s {print $3, $4, $5, $6}' "$W/m_${array}_${t}_active.txt"))
        m=($(awk -v s="$set" '$1 == s {print $3, $4, $5, $6}' "$W/m_${array}_${t}_magnitude.txt"))
        echo "| $(label "$t") | $set | $frames | ${a[0]} | ${a[1]} | ${a[2]} | ${a[3]} | ${m[0]} | ${m[1]} | ${m[2]} | ${m[3]} |"
      done < "$W/m_${array}_${t}_active.txt"
    done
    echo
  done
} >> "$OUT"

# The page's claims.
for f in active magnitude; do
  for s in anechoic_3dB; do
    claim "imperfect array, anechoic table, $s, $f: ACC10 ≥ 95 %" \
      "$(metric imperfect imperfect_anechoic $f $s acc10) >= 95"
    claim "imperfect array, anechoic table, $s, $f: MAE ≤ 2.5°" \
      "$(metric imperfect imperfect_anechoic $f $s mae) <= 2.5"
  done
  for s in anechoic_0dB anechoic_10dB; do
    claim "imperfect array, anechoic table, $s, $f: MAE ≤ 1.5°" \
      "$(metric imperfect imperfect_anechoic $f $s mae) <= 1.5"
  done
  for s in room_0dB room_3dB room_10dB; do
    claim "imperfect array, anechoic table, $s, $f: ACC10 ≥ 95 %, MAE ≤ 3.5°" \
      "$(metric imperfect imperfect_anechoic $f $s acc10) >= 95 && $(metric imperfect imperfect_anechoic $f $s mae) <= 3.5"
    claim "imperfect array, room table in its room, $s, $f: ACC10 ≥ 95 %, MAE ≤ 3.5°" \
      "$(metric imperfect imperfect_room $f $s acc10) >= 95 && $(metric imperfect imperfect_room $f $s mae) <= 3.5"
  done
  for s in anechoic_0dB anechoic_3dB anechoic_10dB room_0dB room_3dB room_10dB; do
    claim "imperfect array, ideal table, $s, $f: MAE ≥ 5° (the measured table is needed)" \
      "$(metric imperfect ideal $f $s mae) >= 5"
    claim "imperfect array, $s, $f: --symmetry on mismatched capsules is worse than the full circle" \
      "$(metric imperfect imperfect_symmetry $f $s mae) > $(metric imperfect imperfect_anechoic $f $s mae)"
    claim "ideal array, anechoic table vs ideal model, $s, $f: MAE within 0.1°, ACC10 within 0.5 points" \
      "($(metric ideal ideal_anechoic $f $s mae) - $(metric ideal ideal $f $s mae))^2 <= 0.01 && $(metric ideal ideal_anechoic $f $s acc10) >= $(metric ideal ideal $f $s acc10) - 0.5"
    claim "imperfect array, $s, $f: the 15° table with 21 rows: ACC10 ≥ 95 %, MAE within 1° of the 5° table" \
      "$(metric imperfect imperfect_anechoic_15deg $f $s acc10) >= 95 && $(metric imperfect imperfect_anechoic_15deg $f $s mae) <= $(metric imperfect imperfect_anechoic $f $s mae) + 1"
    claim "imperfect array, $s, $f: 83 rows within 0.2° of 42 rows" \
      "($(metric imperfect imperfect_anechoic_83rows $f $s mae) - $(metric imperfect imperfect_anechoic $f $s mae))^2 <= 0.04"
  done
done
claim "--symmetry on the imperfect array warns that the capsules disagree" \
  "$(grep -c 'disagree by' "$W/imperfect_symmetry.log") == 1"
claim "no symmetry warning without --symmetry" \
  "$(cat "$W"/imperfect_anechoic.log "$W"/ideal_anechoic.log | grep -c 'disagree by' || true) == 0"

cat "$OUT" "$CLAIMS"
echo "$(grep -c '^claim holds' "$CLAIMS") claims hold, $(grep -c '^CLAIM FAILED' "$CLAIMS" || true) failed"
if [ "$UPDATE" = --update-doc ]; then
  doc=docs/calibration.md
  awk -v res="$OUT" '
    /<!-- BEGIN calibration_experiment.sh/ {print; print "<!-- generated by docs/calibration_experiment.sh --update-doc; do not edit by hand -->"; print ""; while ((getline l < res) > 0) print l; skip = 1; next}
    /<!-- END calibration_experiment.sh/ {print ""; skip = 0}
    !skip {print}' "$doc" > "$doc.new"
  mv "$doc.new" "$doc"
  echo "updated $doc"
fi
exit $FAILED
