#!/usr/bin/env bash
# Decoupled shading's first measurements (docs/DECOUPLED.md), on the built-in `default` (depth of field,
# a moving sphere, a panning camera) at 160×90, S = 16:
#  * the cache-size sweep: one interleaved `shutter bench` of per-sample and per-pixel shading and
#    decoupled shading on the pixel grid and on the AAS grids, with a memoization cache and with the
#    deferred mode's hash table of 64 … 65536 entries, with the counters' frame (lookups, hits,
#    evictions, lost stores, overflows; shading invocations);
#  * the distinct keys (shading points) of the pixel, isotropic-AAS and AAS grids on four scenes, from
#    the reference (`shutter reference --shading …`: the least any cache can shade); the sweep plotted
#    against them (scripts/plot-cache-sweep.py);
#  * error against a 1024-spp reference: one interleaved `shutter quality` per scene (`default`,
#    `one-mover`) of every shading mode — per-pixel, per-sample, decoupled and AAS with either cache,
#    texture-space (ATSS) — at S = 4, 16 and 64;
#  * shading cost as a dial: the ATSS light-dial scenes (scripts/atss-lights.sh, 1–256 point lights),
#    per-sample, per-pixel, decoupled and AAS shading with either cache (64k entries) and texture-space
#    shading (ATSS) at S = 8, one interleaved bench per count.
# About 25 minutes on the 2-core VM (llvmpipe); QUALITY_ONLY=1 runs the quality sweeps only.
# Needs a release build (cargo build --release); writes docs/quality/decoupled/.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shutter
mkdir -p docs/quality/decoupled
if [ -z "${QUALITY_ONLY:-}" ]; then
configs=(-c stochastic:shading=per-sample -c stochastic:shading=per-pixel)
for grid in decoupled aas decoupled-deferred aas-deferred; do
  for n in 64 256 1024 4096 16384 32768 65536; do
    configs+=(-c "stochastic:shading=$grid:cache=$n")
  done
done
$S bench default --size 160x90 --spp 16 --frames 3 --warmup 1 "${configs[@]}" \
  --csv docs/quality/decoupled/cache-default.csv > docs/quality/decoupled/cache-default.md
{
  echo "| scene | decoupled (pixel grid) | aas-isotropic | aas |"
  echo "|---|---:|---:|---:|"
  for scene in default one-mover glass focus-sweep; do
    row="| \`$scene\`"
    for grid in decoupled aas-isotropic aas; do
      keys=$($S reference "$scene" --shading "$grid" --spp 16 --size 160x90 --out out/decoupled-keys.exr \
        | sed -n 's/^decoupled shading: \([0-9]*\) distinct keys.*/\1/p')
      row="$row | $keys"
    done
    echo "$row |"
  done
} > docs/quality/decoupled/keys.md
python3 scripts/plot-cache-sweep.py docs/quality/decoupled/cache-default.csv docs/quality/decoupled/keys.md \
  docs/quality/decoupled/cache-default.svg
SCENES_ONLY=1 bash scripts/atss-lights.sh
for n in 1 16 64 256; do
  $S bench "out/atss/lights-$n.toml" --spp 8 --frames 3 --warmup 1 \
    -c stochastic:shading=per-sample -c stochastic:shading=per-pixel -c stochastic:shading=decoupled \
    -c stochastic:shading=decoupled-deferred -c stochastic:shading=aas -c stochastic:shading=aas-deferred \
    -c stochastic:shading=texture-space > "docs/quality/decoupled/lights-$n-s8.md"
done
fi
for scene in default one-mover; do
  rm -f "docs/quality/decoupled/quality-$scene.csv"
  series=()
  for shading in per-pixel per-sample decoupled decoupled-deferred aas aas-deferred texture-space; do
    series+=(-s "stochastic:shading=$shading@4,16,64")
  done
  $S quality "$scene" --size 160x90 --reference-spp 1024 --cache out/cache --frames 1 --warmup 1 \
    "${series[@]}" --out "docs/quality/decoupled/quality-$scene"
done
# Images at S = 64 on `default` against the reference quality cached: per mode the image and its FLIP
# map (the deferred modes' images are the memoization modes').
hash=$(sed -n 's/.*content hash \([0-9a-f]*\).*/\1/p' docs/quality/decoupled/quality-default.md)
ref=$(ls -t out/cache/reference-v*-"$hash"-160x90-1024spp-seed1.exr | head -1)
mkdir -p docs/quality/decoupled/images
for shading in per-sample per-pixel decoupled aas texture-space; do
  $S render default --technique stochastic --shading "$shading" --size 160x90 --spp 64 \
    --out "out/decoupled-$shading-s64.exr" > /dev/null
  $S convert "out/decoupled-$shading-s64.exr" "docs/quality/decoupled/images/default-$shading-s64.png"
  $S compare "$ref" "out/decoupled-$shading-s64.exr" --diff "docs/quality/decoupled/images/default-$shading-s64-flip.png" \
    > /dev/null
done
$S convert "$ref" docs/quality/decoupled/images/default-reference.png
