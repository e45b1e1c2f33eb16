#!/usr/bin/env bash
# Interleaved deferred shading's image quality, by its CPU mirror (engine/src/mirror/interleaved.rs,
# `shutter reference --vpls N --interleave NxM`), on the built-in `cornell` at 160×120 with 1024 photons
# (880 VPLs on `cornell`) clamped at 0.1, and on the textured `interior` alike (docs/INTERLEAVED.md): every pattern (2x2, 4x4, 8x6, 8x8) × filter (none,
# plain Gaussian, the paper's edge-aware one, per-axis edges, the paper's with bilinear pairs) against the
# brute force (1x1, no filter) with the same VPL visibility — shadow rays (the paper's SSM) and none
# (SNSM) — RMSE and FLIP (`shutter compare`), and the images and FLIP maps of 4x4.
# The GPU technique renders the same images (tests/tests/interleaved.rs); its speed is measured by
# scripts/interleaved-bench.sh. The CPU seconds here are those of a single-threaded mirror. Needs a release build; writes docs/quality/interleaved/.
# About two minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shutter
out=docs/quality/interleaved
tmp=out/interleaved
mkdir -p "$out" "$tmp"
run() { $S reference "$scene" --size 160x120 --vpls 1024 --clamp 0.1 "$@" | sed -n 's/.* in \([0-9.]*\) s;.*/\1/p'; }
metrics() { $S compare "$1" "$2" | awk '/^RMSE/{r=$2} /^FLIP/{f=$2} END{print r" | "f}'; }
for scene in cornell interior; do
{
  for vis in ssm snsm; do
    flag=""
    [ "$vis" = snsm ] && flag="--snsm"
    brute="$tmp/$scene-brute-$vis.exr"
    secs=$(run --interleave 1x1 --filter none $flag --out "$brute")
    echo ""
    echo "VPL visibility: $vis (brute force: ${secs} s on the CPU)"
    echo ""
    echo "| pattern | filter | CPU s | RMSE | FLIP |"
    echo "|---|---|---:|---:|---:|"
    for pattern in 2x2 4x4 8x6 8x8; do
      for filter in none plain full axis full-bilinear; do
        f=${filter%-bilinear}
        extra=""
        [ "$filter" = full-bilinear ] && extra="--bilinear"
        img="$tmp/$scene-$vis-$pattern-$filter.exr"
        secs=$(run --interleave "$pattern" --filter "$f" $extra $flag --out "$img")
        echo "| $pattern | $filter | $secs | $(metrics "$brute" "$img") |"
      done
    done
  done
} > "$out/interleaved-$scene.md"
$S convert "$tmp/$scene-brute-ssm.exr" "$out/$scene-brute-force.png" > /dev/null
for filter in none plain full axis; do
  $S convert "$tmp/$scene-ssm-4x4-$filter.exr" "$out/$scene-4x4-$filter.png" > /dev/null
  $S compare "$tmp/$scene-brute-ssm.exr" "$tmp/$scene-ssm-4x4-$filter.exr" --diff "$out/$scene-4x4-$filter-flip.png" > /dev/null
done
cat "$out/interleaved-$scene.md"
done
# The GPU technique against the ground truth (the path-traced one-bounce reference at 1024 spp,
# cached): FLIP and RMSE against GPU ms, VPL shadow maps on (32² a face) for the brute force and every
# pattern, off for the brute force and 4x4 (no VPL visibility), and 4,096 photons at 4x4.
rm -f "$out/quality-cornell.csv"
$S quality cornell --size 160x120 --reference-spp 1024 --cache out/cache --frames 1 --warmup 1 \
  -s "interleaved:pattern=1x1:filter=none:vpl-maps=32@1" -s "interleaved:pattern=2x2:vpl-maps=32@1" \
  -s "interleaved:pattern=4x4:vpl-maps=32@1" -s "interleaved:pattern=8x6:vpl-maps=32@1" \
  -s "interleaved:pattern=8x8:vpl-maps=32@1" -s "interleaved:pattern=1x1:filter=none:vpl-maps=off@1" \
  -s "interleaved:pattern=4x4:vpl-maps=off@1" -s "interleaved:pattern=4x4:vpls=4096:vpl-maps=16@1" \
  --out "$out/quality-cornell"
# Depth of field and motion (scenes/cornell-blur.toml): `spp` accumulated interleaved passes (one
# G-buffer and, the scene moving, one VPL set per pass) against the bounce-ray reference at 1024 spp —
# error against GPU ms as the passes grow, the brute force, 4x4 and 8x6, without and with VPL maps.
rm -f "$out/quality-cornell-blur.csv"
$S quality scenes/cornell-blur.toml --size 160x120 --reference-spp 1024 --cache out/cache --frames 1 --warmup 1 \
  -s "interleaved:pattern=1x1:filter=none:vpl-maps=off@1,4,16" -s "interleaved:pattern=4x4:vpl-maps=off@1,4,16,64" \
  -s "interleaved:pattern=8x6:vpl-maps=off@4,16,64" -s "interleaved:pattern=4x4:vpl-maps=16@4,16" \
  -s "interleaved:pattern=1x1:filter=none:vpl-maps=16@4" \
  --out "$out/quality-cornell-blur"
