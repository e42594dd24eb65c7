#!/usr/bin/env bash
# Instructions executed by the emulated Cortex-M4F (QEMU mps2-an386) per analysis hop of cma-core
# (default configuration, 48 kHz input, hop = 1024 input samples = 256 analysis samples). Needs gcc
# and qemu-system-arm.
#
# 1. The budget check, for what the firmware runs: every hop of five input kinds (speech, clipping
#    bursts, NaN bursts, silence, full-scale noise; qemu-check/src/inputs.rs) fed in the firmware's
#    blocks (qemu_check::FIRMWARE_BLOCK sample frames), counted hop by hop: the TCG plugin follows
#    the program's mark functions, leaving out input generation. Mean and worst hop per kind; the
#    script exits with status 1 when the worst hop of any kind is above BUDGET (default 150000).
# 2. Per stage (256-frame blocks of the test scene): each figure is the difference of two runs (many
#    and few repetitions) divided by the difference in repetitions, so start-up cancels; the pipeline
#    figure also subtracts the cost of generating the scene.
# 3. The multi-talker configuration (the default with the multi-talker tracks on) on the same scene,
#    counted like the pipeline.
set -euo pipefail
cd "$(dirname "$0")/.."
TARGET=thumbv7em-none-eabihf
TARGET_DIR=${CARGO_TARGET_DIR:-target}
ELF=$TARGET_DIR/$TARGET/release/qemu-check
PLUGIN=$TARGET_DIR/insn-count.so
MODE_ADDR=0x20300000
ARG_ADDR=0x20300004
BUDGET=${BUDGET:-150000}
CEILING=${CEILING:-180000}
HOPS=150
NM="$(rustc --print sysroot)/lib/rustlib/x86_64-unknown-linux-gnu/bin/llvm-nm"

mkdir -p "$TARGET_DIR"
gcc -O2 -shared -fPIC -o "$PLUGIN" scripts/insn-count.c
cargo build -q -p qemu-check --release --target $TARGET

# count MODE ARG → instructions executed by the whole run
count() {
    timeout 300 qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
        -semihosting-config enable=on,target=native -kernel "$ELF" \
        -plugin "$PLUGIN" -d plugin \
        -device loader,addr=$MODE_ADDR,data="$1",data-len=4 \
        -device loader,addr=$ARG_ADDR,data="$2",data-len=4 2>&1 |
        awk '/^insns /{print $2}'
}

# per_rep MODE FEW MANY → instructions per repetition
per_rep() {
    local a b
    a=$(count "$1" "$2")
    b=$(count "$1" "$3")
    echo $(((b - a) / ($3 - $2)))
}

# mark NAME → address of the program's function cost_mark_NAME
mark() {
    "$NM" -C "$ELF" | awk -v n="cost_mark_$1" '$3 ~ n {print "0x" $1}'
}

# hops KIND → one line per hop: instructions since the previous estimate (generation left out)
hops() {
    timeout 300 qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
        -semihosting-config enable=on,target=native -kernel "$ELF" \
        -plugin "$PLUGIN,hop=$(mark hop),pause=$(mark pause),resume=$(mark resume)" -d plugin \
        -device loader,addr=$MODE_ADDR,data=8,data-len=4 \
        -device loader,addr=$ARG_ADDR,data=$(($1 + (HOPS << 8))),data-len=4 2>&1 |
        awk '/^hop /{print $2}'
}

commit="$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- core-nostd qemu-check || echo '+dirty')"
block=$(sed -n 's/^pub const FIRMWARE_BLOCK: usize = \([0-9]*\);/\1/p' qemu-check/src/lib.rs)
printf 'cma-core on emulated Cortex-M4F (QEMU mps2-an386), default configuration, 48 kHz input\n'
printf 'commit %s\n\n' "$commit"
printf '### Per hop in the firmware'"'"'s blocks (%s sample frames), %d hops per input (the first, start-up, left out)\n\n' "$block" "$HOPS"
printf '| input | mean | worst hop | best hop | worst hop, cycles (model: 1.46 per instruction) | of a 21.33 ms hop at 100 MHz |\n'
printf '|---|---:|---:|---:|---:|---:|\n'
names=("speech" "clipping bursts" "NaN bursts" "silence" "full-scale noise")
worst_all=0
for k in 0 1 2 3 4; do
    read -r mean worst best < <(hops $k | awk 'NR > 1 {s += $1; n++; if ($1 > w) w = $1; if (b == "" || $1 < b) b = $1}
        END {if (n == 0) {print 0, 0, 0} else {printf "%d %d %d\n", s / n, w, b}}')
    [ "$worst" -gt 0 ] || { echo "no hops counted for input ${names[$k]}" >&2; exit 1; }
    [ "$worst" -gt "$worst_all" ] && worst_all=$worst
    printf '| %s | %d | %d | %d | %d | %.1f %% |\n' "${names[$k]}" "$mean" "$worst" "$best" \
        "$(awk -v w="$worst" 'BEGIN{printf "%d", 1.46 * w}')" \
        "$(awk -v w="$worst" 'BEGIN{print 100 * 1.46 * w / (100e6 * 1024 / 48000)}')"
done
printf '\nbudget: worst hop ≤ %d instructions: %s (worst %d)\n\n' "$BUDGET" \
    "$([ "$worst_all" -le "$BUDGET" ] && echo met || echo NOT met)" "$worst_all"

printf '### Per stage (the test scene in 256-frame blocks)\n\n'
pipe=$(per_rep 1 20 120)
gen=$(per_rep 2 20 120)
total=$((pipe - gen))

printf '| stage | instructions per hop | share |\n|---|---:|---:|\n'
sum=0
names=(front-end spectra peaks similarity reliability)
descr=("input guard, ×4 decimation, framing (1024 input samples × 4 ch)"
       "omni windowed 512-point real FFT + 3 cardioid frames windowed and 16-folded"
       "omni power spectrum + peak picking"
       "cardioid DFT at the peaks, features, similarity curve (noisy references)"
       "curve variance, reliability filter, 2 × interpolated argmax")
for i in 0 1 2 3 4; do
    c=$(per_rep $((i + 3)) 2 22)
    sum=$((sum + c))
    printf '| %s — %s | %d | %d %% |\n' "${names[$i]}" "${descr[$i]}" "$c" $((100 * c / total))
done
printf '| rest — frame power, estimate assembly, call overhead | %d | %d %% |\n' \
    $((total - sum)) $((100 * (total - sum) / total))
printf '| **whole pipeline** | **%d** | 100 %% |\n\n' "$total"

multi=$(($(per_rep 9 20 120) - gen))
printf '### Multi-talker configuration (the default with the multi-talker tracks on, same scene)\n\n'
printf '| configuration | instructions per hop | cycles (model: 1.46 per instruction) | of a 21.33 ms hop at 100 MHz |\n|---|---:|---:|---:|\n'
printf '| multi-talker tracks on | %d | %d | %.1f %% |\n' "$multi" \
    "$(awk -v w="$multi" 'BEGIN{printf "%d", 1.46 * w}')" \
    "$(awk -v w="$multi" 'BEGIN{print 100 * 1.46 * w / (100e6 * 1024 / 48000)}')"
printf '| of which the multi-talker stage | %d | | |\n\n' $((multi - total))

if [ "$worst_all" -gt "$CEILING" ]; then
    echo "FAIL: the worst hop ($worst_all instructions) is above the regression ceiling of $CEILING" >&2
    exit 1
fi
if [ "$total" -gt "$BUDGET" ]; then
    echo "FAIL: the pipeline in 256-frame blocks ($total instructions per hop) is above the budget of $BUDGET" >&2
    exit 1
fi
