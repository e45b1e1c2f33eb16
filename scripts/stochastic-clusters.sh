#!/usr/bin/env bash
# The measurements of docs/STOCHASTIC.md, "Cluster bounds": lavapipe unless SHUTTER_DEVICE says otherwise.
#   1. per scene, one interleaved `shutter bench`: accumulation, one bound per triangle
#      (`clusters=off`) and the default (`clusters=auto`), at the sizes of the ablation tables;
#   2. the cluster size on focus-sweep (160×90, S = 16): off, 4, 8, 16, 32, 64 triangles per cluster;
#   3. what accuracy costs in time with the defaults: `shutter quality` sweeps of accumulation and
#      stochastic on default, one-mover and focus-sweep against the cached 4096-spp references (the
#      same series as scripts/stochastic-ablation.sh, section 3).
# About 15 minutes on a 2-core machine when the references are cached (out/cache), an hour more when not.
# Usage: scripts/stochastic-clusters.sh [BIN]   (default target/release/shutter)
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${1:-target/release/shutter}
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
OUT=docs/quality/stochastic
mkdir -p "$OUT" out/cache

echo "== 1. cluster bounds against one bound per triangle"
for c in "default 320x180 16 3" "one-mover 320x180 16 3" "focus-sweep 96x54 4 1" "focus-sweep 160x90 16 1"; do
  read -r scene size spp frames <<<"$c"
  "$BIN" bench "$scene" --size "$size" --spp "$spp" --frames "$frames" --warmup 1 \
    -c accumulation -c stochastic:clusters=off -c stochastic -c stochastic:shading=per-sample \
    --json "$OUT/clusters-$scene-$size.json" | tee "$OUT/clusters-$scene-$size.md"
done

echo "== 2. triangles per cluster, focus-sweep"
"$BIN" bench focus-sweep --size 160x90 --spp 16 --frames 1 --warmup 1 \
  -c stochastic:clusters=off -c stochastic:clusters=4 -c stochastic:clusters=8 -c stochastic:clusters=16 \
  -c stochastic:clusters=32 -c stochastic:clusters=64 \
  --json "$OUT/cluster-size-focus-sweep.json" | tee "$OUT/cluster-size-focus-sweep.md"

echo "== 3. what accuracy costs in time, the defaults"
"$BIN" quality default --size 160x90 --reference-spp 4096 --cache out/cache \
  -s accumulation@4,16,64,256 -s stochastic@4,16,64 -s stochastic:shading=per-sample@4,16 \
  --frames 1 --warmup 1 --out "$OUT/quality-default-clusters"
"$BIN" quality one-mover --size 160x90 --reference-spp 4096 --cache out/cache \
  -s accumulation@4,16,64,256 -s stochastic@4,16,64 -s stochastic:shading=per-sample@4,16 \
  --frames 1 --warmup 1 --out "$OUT/quality-one-mover-clusters"
"$BIN" quality focus-sweep --size 96x54 --reference-spp 4096 --cache out/cache \
  -s accumulation@4,16,64,256 -s stochastic@4,16,64 -s stochastic:shading=per-sample@4,16 \
  --frames 1 --warmup 0 --out "$OUT/quality-focus-sweep-clusters"
