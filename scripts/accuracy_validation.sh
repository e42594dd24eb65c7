#!/bin/bash
# Builds an independent validation folder for the tracker (not the files of /work/shared/data/eval):
# 12 static room scenes (2 measured RIRs, 5-15 dB), 2 jump and 2 circling (30 deg/s, synthetic
# speech, 12 s), 3 circling with real speech (3 s), 3 static anechoic at 0 dB.
# Usage: scripts/accuracy_validation.sh OUT_DIR   then   host-sim eval OUT_DIR
set -e
H=${HS:-$(cd "$(dirname "$0")/.." && pwd)/target/release/host-sim}
S=/work/shared/data/src/speech
R=/work/shared/data/src/rir
O=${1:?output folder}
rm -rf $O; mkdir -p $O
src=($S/*.wav)
i=0
for az in 15 70 130 200 255 320; do
  f=${src[$((i % 7))]}
  $H scene --out $O/marco_az$az.wav --source $f --azimuth $az --rir $R/marco_p90deg_3m_FOA_ACN_SN3D.wav --rir-direct 80 --snr $((5 + (i%3)*5)) --seed $((i+10)) --manifest $O/manifest.csv --set room_marco >/dev/null
  i=$((i+1))
done
for az in 40 100 165 230 290 345; do
  f=${src[$((i % 7))]}
  $H scene --out $O/gew_az$az.wav --source $f --azimuth $az --rir $R/IR_Gewandhaus_SH1.wav --rir-n3d --snr $((5 + (i%3)*5)) --seed $((i+10)) --manifest $O/manifest.csv --set room_gew >/dev/null
  i=$((i+1))
done
$H scene --out $O/jump1.wav --synth 12 --track 0:-30,2:120,4:-100,6:10,8:-170,10:60 --rir $R/marco_p90deg_3m_FOA_ACN_SN3D.wav --rir-direct 80 --snr 5 --seed 3 --manifest $O/manifest.csv --set jump >/dev/null
$H scene --out $O/jump2.wav --synth 12 --track 0:170,2:45,4:-60,6:-175,8:90,10:-20 --rir $R/IR_Gewandhaus_SH1.wav --rir-n3d --snr 5 --seed 4 --manifest $O/manifest.csv --set jump >/dev/null
$H scene --out $O/move1.wav --synth 12 --rotate 30 --start-azimuth -50 --rir $R/marco_p90deg_3m_FOA_ACN_SN3D.wav --rir-direct 80 --snr 6 --seed 5 --manifest $O/manifest.csv --set moving >/dev/null
$H scene --out $O/move2.wav --synth 12 --rotate -30 --start-azimuth 100 --rir $R/IR_Gewandhaus_SH1.wav --rir-n3d --snr 6 --seed 6 --manifest $O/manifest.csv --set moving >/dev/null
# Real speech while moving / static anechoic (short files, ~3 s each).
$H scene --out $O/mvs1.wav --source $S/cmu_arctic_us_axb_a0004.wav --rotate 30 --start-azimuth 20 --rir $R/marco_p90deg_3m_FOA_ACN_SN3D.wav --rir-direct 80 --snr 10 --seed 7 --manifest $O/manifest.csv --set moving_speech >/dev/null
$H scene --out $O/mvs2.wav --source $S/cmu_arctic_us_aew_a0002.wav --rotate -30 --start-azimuth -140 --rir $R/IR_Gewandhaus_SH1.wav --rir-n3d --snr 10 --seed 8 --manifest $O/manifest.csv --set moving_speech >/dev/null
$H scene --out $O/mvs3.wav --source $S/arctic_a0010.wav --rotate 30 --start-azimuth 150 --rir $R/IR_Gewandhaus_SH1.wav --rir-n3d --snr 5 --seed 9 --manifest $O/manifest.csv --set moving_speech >/dev/null
for az in 33 147 261; do
  $H scene --out $O/anech_az$az.wav --source $S/cmu_arctic_us_axb_a0006.wav --azimuth $az --snr 0 --seed $az --manifest $O/manifest.csv --set anechoic >/dev/null
done
