#!/usr/bin/env bash
# Regenerates the tables and images of docs/STOCHASTIC.md (lavapipe unless SHUTTER_DEVICE says otherwise).
# Slow on a 2-core machine (about an hour in all): each block can be run on its own.
# Usage: scripts/stochastic-docs.sh            (after scripts/setup.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --bin shutter
S=target/release/shutter
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
mkdir -p docs/images out

echo "== STE and ms of every bound, default, 320x180, S = 4 and 16"
$S bounds default --size 320x180 --spp 4,16 --frames 1 --warmup 1 --out out/bounds-default-320x180.md

echo "== STE and ms of every bound, focus-sweep (327,680-triangle sphere), 96x54, S = 4"
$S bounds focus-sweep --size 96x54 --spp 4 --frames 1 --warmup 0 --out out/bounds-focus-sweep-96x54.md

echo "== 640x360, S = 4 and 16: pinhole, accumulation and every bound (about 30 minutes)"
$S bounds default --size 640x360 --spp 4,16 --frames 1 --warmup 0 --out out/bounds-default-640x360.md

echo "== per-pixel vs per-sample shading against the reference with the same samples (S = 16)"
$S reference default --size 320x180 --spp 16 --seed 1 --out out/default-reference-16.exr
for shading in per-pixel per-sample; do
  $S render default --technique stochastic --spp 16 --seed 1 --size 320x180 --shading $shading \
    --out out/default-stochastic-16-$shading.exr
  $S compare out/default-reference-16.exr out/default-stochastic-16-$shading.exr \
    --diff docs/images/default-stochastic-16-$shading-flip.png
  $S convert out/default-stochastic-16-$shading.exr docs/images/default-stochastic-16-$shading.png
done
$S convert out/default-reference-16.exr docs/images/default-reference-16.png
