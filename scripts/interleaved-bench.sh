#!/usr/bin/env bash
# Technique `interleaved` timed (docs/INTERLEAVED.md): one interleaved `shutter bench` on the built-in
# `cornell` at 640×480 with about 480 VPLs (558 photons; the paper's Table 4 count) — the brute force
# (pattern 1x1, no filter) against 8x6 (the paper's pattern) and the others, split in one pass or two
# by block size, the blur plain, edge-aware, per axis and in bilinear pairs, and without a filter; and
# with the VPLs' cube shadow maps (vpl-maps=32 and 16 texels a face: the paper's SSM) against none (SNSM).
# GPU ms per step come from each pass' timestamps ("per pass"). Needs a release build; writes
# docs/quality/interleaved/bench-{cornell,interior}-640.md and .csv. About a minute on the 2-core VM.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shutter
out=docs/quality/interleaved
mkdir -p "$out"
v=vpls=558
configs=(
  -c "interleaved:$v:pattern=1x1:filter=none:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:filter=none:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:filter=plain:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:filter=axis:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:bilinear=true:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:split=one:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:block=1x1:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:block=2x2:vpl-maps=off"
  -c "interleaved:$v:pattern=8x6:block=8x8:vpl-maps=off"
  -c "interleaved:$v:pattern=2x2:vpl-maps=off"
  -c "interleaved:$v:pattern=4x4:vpl-maps=off"
  -c "interleaved:$v:pattern=8x8:vpl-maps=off"
  -c "interleaved:$v:pattern=1x1:filter=none:vpl-maps=32"
  -c "interleaved:$v:pattern=8x6:vpl-maps=32"
  -c "interleaved:$v:pattern=8x6:vpl-maps=16"
)
$S bench cornell --size 640x480 --frames 3 --warmup 1 --no-counters "${configs[@]}" \
  --csv "$out/bench-cornell-640.csv" > "$out/bench-cornell-640.md"
cat "$out/bench-cornell-640.md"
# The textured interior: the brute force against three patterns.
$S bench interior --size 640x480 --frames 3 --warmup 1 --no-counters -c "interleaved:$v:pattern=1x1:filter=none:vpl-maps=off" \
  -c "interleaved:$v:pattern=4x4:vpl-maps=off" -c "interleaved:$v:pattern=8x6:vpl-maps=off" -c "interleaved:$v:pattern=8x8:vpl-maps=off" \
  --csv "$out/bench-interior-640.csv" > "$out/bench-interior-640.md"
cat "$out/bench-interior-640.md"
# The blur's bilinear pairs lerped in the shader (bilinear=true) against fetched by the hardware's
# linear filter from an image (bilinear=sampler, the paper's trick, with the copy into the image),
# and the plain kernel, at 8x6.
$S bench cornell --size 640x480 --frames 3 --warmup 1 --no-counters -c "interleaved:$v:pattern=8x6:vpl-maps=off" \
  -c "interleaved:$v:pattern=8x6:bilinear=true:vpl-maps=off" -c "interleaved:$v:pattern=8x6:bilinear=sampler:vpl-maps=off" \
  --csv "$out/bench-blur-640.csv" > "$out/bench-blur-640.md"
cat "$out/bench-blur-640.md"
