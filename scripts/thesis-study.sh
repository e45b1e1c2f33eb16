#!/usr/bin/env bash
# The image-quality half of the thesis' study (docs/THESIS.md; Toth & Linder §8, Figs. 3, 15 and 16) on
# docs/scenes/thesis-sweep.toml, against the CPU reference, lavapipe unless SHUTTER_DEVICE says otherwise:
#   1. ghosting (Fig. 3): focus on the buildings, the statue blurred by about 12 px at 320×180;
#      accumulation at 4 and 16 passes next to stochastic rasterization at 4 and 16 samples, images kept;
#   2. samples at equal quality over the whole sweep (Fig. 15's question, at every focus distance of
#      docs/THESIS.md's table): FLIP of accumulation at 4…256 passes and stochastic at 4…64 samples;
#   3. resolution (Fig. 16): the same scene, the same physical circle of confusion, at 160×90, 320×180
#      and 640×360 — accumulation 16 passes against stochastic 16 samples, images kept.
# FLIP is deterministic; the milliseconds are single frames on whatever machine runs this.
# About 25 minutes on a 2-core machine with the references not yet cached (out/cache), 5 when cached.
# Usage: scripts/thesis-study.sh [BIN]   (default target/release/shutter)
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${1:-target/release/shutter}
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
OUT=docs/quality/thesis
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
mkdir -p "$OUT" out/cache
SCENE=docs/scenes/thesis-sweep.toml

# The scene refocused at $1 (scene units), written to $TMP/thesis-sweep-f$1.toml.
refocus() {
  local f=$1 dst="$TMP/thesis-sweep-f$1.toml"
  sed "s/^focus_distance = .*/focus_distance = $f/" "$SCENE" >"$dst"
  grep -q "^focus_distance = $f$" "$dst"
  echo "$dst"
}

echo "== 1. ghosting: focus 30, 320x180"
"$BIN" quality "$(refocus 30)" --size 320x180 --reference-spp 1024 --cache out/cache \
  -s accumulation@4,16 -s stochastic:shading=per-sample@4,16 --frames 1 --warmup 1 --images \
  --out "$OUT/ghosting-f30"

echo "== 2. samples at equal quality across the sweep, 160x90"
for f in 2.5 5 10 30; do
  "$BIN" quality "$(refocus $f)" --size 160x90 --reference-spp 4096 --cache out/cache \
    -s accumulation@4,16,64,256 -s stochastic:shading=per-sample@4,16,64 --frames 1 --warmup 1 \
    --out "$OUT/equal-quality-f${f/./p}"
done

echo "== 3. resolution: the same circle of confusion in scene units, three image sizes"
for size in 160x90 320x180 640x360; do
  "$BIN" quality "$(refocus 30)" --size "$size" --reference-spp 1024 --cache out/cache \
    -s accumulation@16 -s stochastic:shading=per-sample@16 --frames 1 --warmup 1 --images \
    --out "$OUT/resolution-$size"
done
