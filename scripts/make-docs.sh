#!/usr/bin/env bash
# Regenerates docs/images/ and prints every number quoted in docs/RESULTS.md (same commands).
# Usage: scripts/make-docs.sh            (after scripts/setup.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --bin shutter
S=target/release/shutter
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
mkdir -p docs/images out
echo "== machine"; nproc; grep -m1 "model name" /proc/cpuinfo || true
$S probe | head -3

echo "== CPU reference benchmark: default, 320x180, 256 spp"
$S reference default --size 320x180 --spp 256 --out out/default-reference-256.exr
$S reference static --size 320x180 --spp 256 --out out/static-reference-256.exr

echo "== pinhole vs reference, static"
$S render static --technique pinhole --size 320x180 --out out/static-pinhole.exr
$S compare out/static-reference-256.exr out/static-pinhole.exr --diff docs/images/static-pinhole-flip.png

echo "== pinhole vs reference, default (the no-blur image against the blurred truth)"
$S render default --technique pinhole --size 320x180 --out out/default-pinhole.exr
$S compare out/default-reference-256.exr out/default-pinhole.exr

for p in 4 16 64 256; do
  echo "== accumulation $p passes vs reference, default"
  $S render default --technique accumulation --spp $p --size 320x180 --out out/default-accumulation-$p.exr
  $S compare out/default-reference-256.exr out/default-accumulation-$p.exr
done

$S convert out/default-reference-256.exr docs/images/default-reference-256.png
$S convert out/static-pinhole.exr docs/images/static-pinhole.png
$S convert out/default-pinhole.exr docs/images/default-pinhole.png
$S convert out/default-accumulation-4.exr docs/images/default-accumulation-4.png
$S convert out/default-accumulation-64.exr docs/images/default-accumulation-64.png
