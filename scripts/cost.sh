#!/usr/bin/env bash
# Instructions executed by the emulated Cortex-M4F (QEMU mps2-an386) per analysis hop of cma-core
# (default configuration, at the firmware's sample rate qemu_check::FIRMWARE_RATE_HZ = the boards'
# ADC rate: 16 kHz, where the core does not decimate and a hop is 256 input samples = 16 ms). Needs
# gcc and qemu-system-arm.
#
# Usage: scripts/cost.sh [--readme]
#   --readme  also writes the generated tables into firmware/README.md, between its markers
#             "<!-- cost.sh: begin -->" and "<!-- cost.sh: end -->".
#
# 1. The budget check, for what the firmware runs: every hop of five input kinds (speech, clipping
#    bursts, NaN bursts, silence, full-scale noise; qemu-check/src/inputs.rs) fed in the firmware's
#    blocks (qemu_check::FIRMWARE_BLOCK sample frames), counted hop by hop: the TCG plugin follows
#    the program's mark functions, leaving out input generation. Mean and worst hop per kind, and a
#    cycle estimate of the worst hop (model below). The script exits with status 1 when the worst hop
#    of any kind is above BUDGET (default 150000).
# 2. The same inputs in other block sizes (what a larger DMA block in the firmware would save).
# 3. Per stage (256-frame blocks of the test scene, at the same rate): each figure is the difference of two runs (many
#    and few repetitions) divided by the difference in repetitions, so start-up cancels; the pipeline
#    figure also subtracts the cost of generating the scene.
#    The same five inputs with the multi-talker tracks on (the firmware's `multi-talker` build), in
#    the budget check too.
# 4. The multi-talker configuration (the default with the multi-talker tracks on) on the same scene,
#    counted like the pipeline.
#
# Cycle model (an estimate; nothing is measured on hardware): low = 1.46 cycles per instruction (the
# ratio an independent review estimated for this code on an M4 with zero-wait memory); high = low plus
# 3 wait states (the STM32F411's flash latency at 100 MHz) for every 16-byte flash line of the code
# executed in the hop (its bytes / 16, counted by the plugin), i.e. as if the ART accelerator's
# prefetch and cache hid none of them. Flash data reads (tables) are in neither figure.
set -euo pipefail
cd "$(dirname "$0")/.."
TARGET=thumbv7em-none-eabihf
TARGET_DIR=${CARGO_TARGET_DIR:-target}
ELF=$TARGET_DIR/$TARGET/release/qemu-check
PLUGIN=$TARGET_DIR/insn-count.so
MODE_ADDR=0x20300000
ARG_ADDR=0x20300004
BUDGET=${BUDGET:-150000}
README=firmware/README.md
write_readme=0
case "${1:-}" in
    --readme) write_readme=1 ;;
    "") ;;
    *) echo "usage: scripts/cost.sh [--readme]" >&2; exit 2 ;;
esac
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

# hops KIND [BLOCK [MULTI]] → one line per hop: instructions and their bytes of code since the
# previous estimate (generation left out); BLOCK 0 (the default) is the firmware's; MULTI 1 runs the
# default with the multi-talker tracks on
hops() {
    timeout 300 qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic \
        -semihosting-config enable=on,target=native -kernel "$ELF" \
        -plugin "$PLUGIN,hop=$(mark hop),pause=$(mark pause),resume=$(mark resume)" -d plugin \
        -device loader,addr=$MODE_ADDR,data=8,data-len=4 \
        -device loader,addr=$ARG_ADDR,data=$(($1 + (HOPS << 8) + (${2:-0} << 20) + (${3:-0} << 31))),data-len=4 2>&1 |
        awk '/^hop /{print $2, $3}'
}

# stats → "mean worst best bytes-of-the-worst-hop" of the hop lines on stdin (the first, start-up,
# left out)
stats() {
    awk 'NR > 1 {s += $1; n++; if ($1 > w) {w = $1; wb = $2}; if (b == "" || $1 < b) b = $1}
        END {if (n == 0) {print 0, 0, 0, 0} else {printf "%d %d %d %d\n", s / n, w, b, wb}}'
}

# Thousands separated by a space, as in the README's tables.
num() {
    echo "$1" | sed -e ':a' -e 's/\([0-9]\)\([0-9]\{3\}\)\($\| \)/\1 \2\3/' -e 'ta'
}

commit="$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- core-nostd qemu-check || echo '+dirty')"
block=$(sed -n 's/^pub const FIRMWARE_BLOCK: usize = \([0-9]*\);/\1/p' qemu-check/src/lib.rs)
rate=$(sed -n 's/^pub const FIRMWARE_RATE_HZ: u32 = \([0-9_]*\);/\1/p' qemu-check/src/lib.rs | tr -d _)
# The core's decimation factor at this rate (core-nostd/src/frontend/decimator.rs) and its hop.
case "$rate" in
    44100 | 48000) factor=4 ;;
    88200 | 96000) factor=8 ;;
    22050 | 24000 | 32000) factor=2 ;;
    *) factor=1 ;;
esac
hop_samples=$((256 * factor))
hop_ms=$(awk -v n="$hop_samples" -v r="$rate" 'BEGIN {printf "%.2f", 1000 * n / r}')
if [ "$factor" = 1 ]; then
    front_descr="input guard and framing, no decimation ($hop_samples input samples × 4 ch)"
else
    front_descr="input guard, ×$factor decimation, framing ($hop_samples input samples × 4 ch)"
fi
out=$(mktemp)
trap 'rm -f "$out"' EXIT
{
printf 'Measured by `scripts/cost.sh` at commit %s: cma-core on the emulated Cortex-M4F (QEMU mps2-an386),\n' "$commit"
printf 'default configuration (self-calibration on), %d Hz input (the boards'"'"' ADC rate; a hop is %d input\n' "$rate" "$hop_samples"
printf 'samples), %d hops per input (the first, start-up, left out), in the firmware'"'"'s blocks of %d sample\n' "$HOPS" "$block"
printf 'frames. Cycles: the model in the script'"'"'s header (low:\n'
printf '1.46 per instruction; high: plus 3 flash wait states per 16 bytes of code executed).\n\n'
printf '| input | mean | worst hop | best hop | worst hop, cycles (model, low – high) | of a %s ms hop at 100 MHz |\n' "$hop_ms"
printf '|---|---:|---:|---:|---:|---:|\n'
} >>"$out"
names=("speech" "clipping bursts" "NaN bursts" "silence" "full-scale noise")
worst_all=0
worst_kind=""
# input_rows MULTI → the table rows of the five inputs; keeps the worst hop in worst_all/worst_kind
input_rows() {
    local k mean worst best bytes lo hi plo phi
    for k in 0 1 2 3 4; do
        read -r mean worst best bytes < <(hops $k 0 "$1" | stats)
        [ "$worst" -gt 0 ] || { echo "no hops counted for input ${names[$k]}" >&2; exit 1; }
        if [ "$worst" -gt "$worst_all" ]; then
            worst_all=$worst
            worst_kind=${names[$k]}
            [ "$1" = 1 ] && worst_kind="${names[$k]}, multi-talker tracks on"
        fi
        read -r lo hi plo phi < <(awk -v w="$worst" -v b="$bytes" -v ms="$hop_ms" 'BEGIN {
            lo = 1.46 * w; hi = lo + 3 * b / 16; c = 100e6 * ms / 1000
            printf "%d %d %.1f %.1f\n", lo, hi, 100 * lo / c, 100 * hi / c}')
        printf '| %s | %s | %s | %s | %s – %s | %s – %s %% |\n' "${names[$k]}" "$(num "$mean")" \
            "$(num "$worst")" "$(num "$best")" "$(num "$lo")" "$(num "$hi")" "$plo" "$phi" >>"$out"
    done
}
input_rows 0
{
printf '\nThe same with the multi-talker tracks on (the firmware built with `--features multi-talker`):\n\n'
printf '| input | mean | worst hop | best hop | worst hop, cycles (model, low – high) | of a %s ms hop at 100 MHz |\n' "$hop_ms"
printf '|---|---:|---:|---:|---:|---:|\n'
} >>"$out"
input_rows 1
if [ "$worst_all" -le "$BUDGET" ]; then
    verdict="met"
else
    verdict="**not met**"
fi
printf '\nBudget (worst hop ≤ %s instructions on every input, in both builds): %s; worst hop %s (%s).\n\n' \
    "$(num "$BUDGET")" "$verdict" "$(num "$worst_all")" "$worst_kind" >>"$out"

{
printf 'The same inputs in other block sizes (mean hop of speech; worst hop over the five inputs):\n\n'
printf '| block (sample frames) | speech, mean | worst hop, all inputs |\n|---:|---:|---:|\n'
} >>"$out"
for b in 32 64 128 256; do
    read -r m _ < <(hops 0 $b | stats)
    w=0
    for k in 0 1 2 3 4; do
        read -r _ wk _ < <(hops $k $b | stats)
        [ "$wk" -gt "$w" ] && w=$wk
    done
    printf '| %d | %s | %s |\n' "$b" "$(num "$m")" "$(num "$w")" >>"$out"
done
printf '\n' >>"$out"

printf '### Per stage (the test scene in 256-frame blocks)\n\n' >>"$out"
pipe=$(per_rep 1 20 120)
gen=$(per_rep 2 20 120)
total=$((pipe - gen))

printf '| stage | instructions per hop | share |\n|---|---:|---:|\n' >>"$out"
sum=0
names=(front-end spectra peaks similarity reliability)
descr=("$front_descr"
       "omni windowed 512-point real FFT + 3 cardioid frames windowed and 16-folded"
       "omni power spectrum + peak picking"
       "cardioid DFT at the peaks, features, similarity curve (noisy references)"
       "curve variance, reliability filter, 2 × interpolated argmax")
for i in 0 1 2 3 4; do
    c=$(per_rep $((i + 3)) 2 22)
    sum=$((sum + c))
    printf '| %s — %s | %s | %d %% |\n' "${names[$i]}" "${descr[$i]}" "$(num "$c")" $((100 * c / total)) >>"$out"
done
printf '| rest — frame power, estimate assembly, call overhead | %s | %d %% |\n' \
    "$(num $((total - sum)))" $((100 * (total - sum) / total)) >>"$out"
printf '| **whole pipeline** | **%s** | 100 %% |\n' "$(num "$total")" >>"$out"

multi=$(($(per_rep 9 20 120) - gen))
printf '\n### Multi-talker configuration (the default with the multi-talker tracks on, same scene)\n\n' >>"$out"
printf '| configuration | instructions per hop | cycles (model: 1.46 per instruction) | of a %s ms hop at 100 MHz |\n|---|---:|---:|---:|\n' "$hop_ms" >>"$out"
printf '| multi-talker tracks on | %s | %s | %.1f %% |\n' "$(num "$multi")" \
    "$(num "$(awk -v w="$multi" 'BEGIN{printf "%d", 1.46 * w}')")" \
    "$(awk -v w="$multi" -v ms="$hop_ms" 'BEGIN{print 100 * 1.46 * w / (100e6 * ms / 1000)}')" >>"$out"
printf '| of which the multi-talker stage | %s | | |\n' "$(num $((multi - total)))" >>"$out"

cat "$out"
if [ "$write_readme" = 1 ]; then
    scripts/write-section.sh "$README" cost.sh <"$out"
    echo "wrote the tables into $README"
fi


if [ "$worst_all" -gt "$BUDGET" ]; then
    echo "FAIL: the worst hop ($worst_all instructions, $worst_kind) is above the budget of $BUDGET" >&2
    exit 1
fi
