#!/usr/bin/env bash
# The measurements of docs/STOCHASTIC.md, "Visibility first: what each lever buys": the tree before
# visibility first (OLD_BIN) against this one (NEW_BIN), lavapipe unless SHUTTER_DEVICE says otherwise.
#   1. each lever alone and stacked, one interleaved `shutter bench` per scene with NEW_BIN;
#   2. OLD_BIN's `stochastic` and `accumulation` on the same scenes and sizes (bench);
#   3. what accuracy costs in time with both binaries: `shutter quality` sweeps of accumulation and
#      stochastic (both shading rates) on default, one-mover and focus-sweep against one cached
#      4096-spp reference per scene; the ratio at equal FLIP is the `quality` table's;
#   4. the device's calibrated bound against `adaptive`;
#   5. the final state of NEW_BIN against accumulation.
# The reports in docs/quality/stochastic/ of sections 1-3 were measured before the device bound and the
# per-object shading boxes landed (section 1 now pins `bound=adaptive` as it was; section 3's NEW
# series run the current defaults, so they come out somewhat faster than the committed ones).
# About 40 minutes on a 2-core machine, most of it OLD_BIN on focus-sweep.
# Usage: scripts/stochastic-ablation.sh OLD_BIN NEW_BIN
#   e.g. git worktree add /tmp/prev 45be632 && (cd /tmp/prev && cargo build --release --bin shutter)
#        scripts/stochastic-ablation.sh /tmp/prev/target/release/shutter target/release/shutter
set -euo pipefail
cd "$(dirname "$0")/.."
OLD=$1
NEW=$2
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
OUT=docs/quality/stochastic
mkdir -p "$OUT" out/cache

# scene size spp frames
CASES=("default 320x180 16 3" "one-mover 320x180 16 3" "focus-sweep 96x54 4 1")

# bench_cases BIN NAME CONFIG...: one interleaved `shutter bench` per case, reports $OUT/NAME-<scene>.
bench_cases() {
  local bin=$1 name=$2
  shift 2
  for c in "${CASES[@]}"; do
    read -r scene size spp frames <<<"$c"
    "$bin" bench "$scene" --size "$size" --spp "$spp" --frames "$frames" --warmup 1 "$@" \
      --json "$OUT/$name-$scene.json" | tee "$OUT/$name-$scene.md"
  done
}

echo "== 1. levers, alone and stacked (NEW_BIN; \`bound=adaptive\` was the default when they were measured)"
bench_cases "$NEW" levers -c accumulation \
  -c stochastic:bound=adaptive:per-pass=4:intervals=1:shading=per-sample \
  -c stochastic:bound=adaptive:per-pass=4:intervals=1 \
  -c stochastic:bound=adaptive:intervals=1 \
  -c stochastic:bound=adaptive \
  -c stochastic:bound=adaptive:shading=per-sample

echo "== 2. the tree before (OLD_BIN)"
bench_cases "$OLD" before -c accumulation -c stochastic -c stochastic:shading=per-sample

echo "== 3. what accuracy costs in time, both binaries"
for bin in NEW OLD; do
  B=${!bin}
  $B quality default --size 160x90 --reference-spp 4096 --cache out/cache \
    -s accumulation@4,16,64,256 -s stochastic@4,16,64 -s stochastic:shading=per-sample@4,16 \
    --frames 1 --warmup 1 --out "$OUT/quality-default-$bin"
  $B quality one-mover --size 160x90 --reference-spp 4096 --cache out/cache \
    -s accumulation@4,16,64,256 -s stochastic@4,16,64 -s stochastic:shading=per-sample@4,16 \
    --frames 1 --warmup 1 --out "$OUT/quality-one-mover-$bin"
  $B quality focus-sweep --size 96x54 --reference-spp 4096 --cache out/cache \
    -s accumulation@4,16,64,256 -s stochastic@4,16 -s stochastic:shading=per-sample@4 \
    --frames 1 --warmup 0 --out "$OUT/quality-focus-sweep-$bin"
done
echo "== 4. the device's calibrated bound (bbox on llvmpipe) against adaptive, NEW_BIN"
bench_cases "$NEW" device-bound --no-counters -c accumulation -c stochastic:bound=adaptive -c stochastic
$NEW calibrate | tee "$OUT/calibrate.md"

echo "== 5. the final state (device bound, shading dispatch over each object's screen box), NEW_BIN"
bench_cases "$NEW" final -c accumulation -c stochastic -c stochastic:shading=per-sample

$NEW probe | tee "$OUT/probe.txt"
