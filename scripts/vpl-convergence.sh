#!/usr/bin/env bash
# Instant radiosity against the path-traced one-bounce reference (docs/INTERLEAVED.md) on the built-in
# `cornell` at 160×120: the reference with a bounce ray per sample at 1024 spp, then the VPL estimate
# (`shutter reference --vpls N`, every pixel gathering every VPL, 16 spp for the pixel area) for
# N = 64 … 4096 photons, unclamped and clamped at 0.1; RMSE and FLIP of each against the reference
# (`shutter compare`), the reference's own noise shown by a second path-traced render at 256 spp.
# Needs a release build; writes docs/quality/interleaved/vpl-cornell.md. About 5 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shutter
out=docs/quality/interleaved
tmp=out/vpl
mkdir -p "$out" "$tmp"
$S reference cornell --size 160x120 --spp 1024 --out "$tmp/pt-1024.exr" > /dev/null
$S reference cornell --size 160x120 --spp 256 --seed 2 --out "$tmp/pt-256.exr" > /dev/null
metrics() { $S compare "$tmp/pt-1024.exr" "$1" | awk '/^RMSE/{r=$2} /^FLIP/{f=$2} END{print r" | "f}'; }
{
  echo "| estimate | VPLs | seconds | RMSE | FLIP |"
  echo "|---|---:|---:|---:|---:|"
  echo "| bounce rays, 256 spp (another seed) | - | - | $(metrics "$tmp/pt-256.exr") |"
  for clamp in 0 0.1; do
    for n in 64 256 1024 4096; do
      line=$($S reference cornell --size 160x120 --spp 16 --vpls "$n" --clamp "$clamp" --out "$tmp/vpl-$n-$clamp.exr")
      vpls=$(echo "$line" | sed -n 's/^instant radiosity: \([0-9]*\) virtual.*/\1/p')
      secs=$(echo "$line" | sed -n 's/.* in \([0-9.]*\) s on.*/\1/p')
      echo "| VPLs of $n photons, clamp $clamp | $vpls | $secs | $(metrics "$tmp/vpl-$n-$clamp.exr") |"
    done
  done
} > "$out/vpl-cornell.md"
$S convert "$tmp/pt-1024.exr" "$out/cornell-reference.png"
$S convert "$tmp/vpl-1024-0.exr" "$out/cornell-vpl-1024.png"
$S convert "$tmp/vpl-1024-0.1.exr" "$out/cornell-vpl-1024-clamped.png"
cat "$out/vpl-cornell.md"
