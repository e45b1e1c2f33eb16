#!/usr/bin/env bash
# Texture-space shading against per-pixel and per-sample shading of the stochastic frame: error
# against the CPU reference vs GPU ms, one interleaved run per scene (docs/ATSS.md). Needs a release
# build (cargo build --release); writes docs/quality/atss/.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shutter
mkdir -p docs/quality/atss
for scene in glass default; do
  rm -f "docs/quality/atss/quality-$scene.csv"
  $S quality "$scene" --size 160x90 --reference-spp 1024 --cache out/cache --frames 1 --warmup 1 --images \
    -s stochastic@4,16,64 \
    -s stochastic:shading=per-sample@4,16,64 \
    -s stochastic:shading=texture-space@4,16,64 \
    --out "docs/quality/atss/quality-$scene"
done
