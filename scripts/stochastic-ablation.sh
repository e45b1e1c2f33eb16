#!/usr/bin/env bash
# The measurements of docs/STOCHASTIC.md, "Visibility first: what each lever buys": the tree before
# visibility first (OLD_BIN) against this one (NEW_BIN), lavapipe unless SHUTTER_DEVICE says otherwise.
#   1. each lever alone and stacked, one interleaved `shutter bench` per scene with NEW_BIN;
#   2. OLD_BIN's `stochastic` and `accumulation` on the same scenes and sizes (bench);
#   3. what accuracy costs in time with both binaries: `shutter quality` sweeps of accumulation and
#      stochastic (both shading rates) on default, one-mover and focus-sweep against one cached
#      4096-spp reference per scene; the ratio at equal FLIP is the `quality` table's;
#   4. the device's calibrated bound against `adaptive` (NEW_BIN; sections 1-3 ran before the device
#      default existed, with `adaptive`, so pass `:bound=adaptive` there to reproduce them exactly);
#   5. the final state of NEW_BIN against accumulation.
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

echo "== 1. levers, alone and stacked (NEW_BIN)"
for c in "${CASES[@]}"; do
  read -r scene size spp frames <<<"$c"
  $NEW bench "$scene" --size "$size" --spp "$spp" --frames "$frames" --warmup 1 \
    -c accumulation \
    -c stochastic:per-pass=4:intervals=1:shading=per-sample \
    -c stochastic:per-pass=4:intervals=1 \
    -c stochastic:intervals=1 \
    -c stochastic \
    -c stochastic:shading=per-sample \
    --json "$OUT/levers-$scene.json" | tee "$OUT/levers-$scene.md"
done

echo "== 2. the tree before (OLD_BIN)"
for c in "${CASES[@]}"; do
  read -r scene size spp frames <<<"$c"
  $OLD bench "$scene" --size "$size" --spp "$spp" --frames "$frames" --warmup 1 \
    -c accumulation -c stochastic -c stochastic:shading=per-sample \
    --json "$OUT/before-$scene.json" | tee "$OUT/before-$scene.md"
done

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
for c in "${CASES[@]}"; do
  read -r scene size spp frames <<<"$c"
  $NEW bench "$scene" --size "$size" --spp "$spp" --frames "$frames" --warmup 1 --no-counters \
    -c accumulation -c stochastic:bound=adaptive -c stochastic \
    --json "$OUT/device-bound-$scene.json" | tee "$OUT/device-bound-$scene.md"
done
$NEW calibrate | tee "$OUT/calibrate.md"
echo "== 5. the final state (device bound, shading dispatch over each object's screen box), NEW_BIN"
for c in "${CASES[@]}"; do
  read -r scene size spp frames <<<"$c"
  $NEW bench "$scene" --size "$size" --spp "$spp" --frames "$frames" --warmup 1 \
    -c accumulation -c stochastic -c stochastic:shading=per-sample \
    --json "$OUT/final-$scene.json" | tee "$OUT/final-$scene.md"
done
$NEW probe | tee "$OUT/probe.txt"
