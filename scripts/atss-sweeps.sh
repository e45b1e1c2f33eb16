#!/usr/bin/env bash
# Texture-space shading (per-sample and per-pixel lookups) against per-pixel and per-sample shading of
# the stochastic frame: error against the CPU reference vs GPU ms at the issue's S = 4, 8, 16, one
# interleaved run per scene (docs/ATSS.md), with every image and its FLIP map. Needs a release build
# (cargo build --release); writes docs/quality/atss/. Scenes as arguments (default: all four).
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shutter
mkdir -p docs/quality/atss
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(glass default arena chess)
for scene in "${scenes[@]}"; do
  rm -f "docs/quality/atss/quality-$scene.csv"
  $S quality "$scene" --size 160x90 --reference-spp 1024 --cache out/cache --frames 1 --warmup 1 --images \
    -s stochastic@4,8,16 \
    -s stochastic:shading=per-sample@4,8,16 \
    -s stochastic:shading=texture-space@4,8,16 \
    -s stochastic:shading=texture-space-per-pixel@4,8,16 \
    --out "docs/quality/atss/quality-$scene"
done
