#!/usr/bin/env bash
# What texture-space shading's view-independence costs (docs/ATSS.md): the atlas is shaded once, seen
# from the lens centre at mid-shutter, so a specular highlight does not move across the aperture as
# the reference's does. `default` (aperture 0.15, specular 0.05–0.5) against the same scene with
# every specular weight set to 0: texture-space's FLIP over per-sample shading's on each, S = 16, one
# interleaved `shutter quality` run per scene. Needs a release build; writes out/atss/default-matte.toml
# and docs/quality/atss/specular-{default,matte}.*.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shutter
mkdir -p out/atss docs/quality/atss
sed -E 's/^specular = .*/specular = 0.0/' scenes/default.toml > out/atss/default-matte.toml
for pair in "default:default" "matte:out/atss/default-matte.toml"; do
  name=${pair%%:*}
  scene=${pair#*:}
  rm -f "docs/quality/atss/specular-$name.csv"
  $S quality "$scene" --size 160x90 --reference-spp 1024 --cache out/cache --frames 1 --warmup 1 \
    -s stochastic:shading=per-sample@16 -s stochastic:shading=texture-space@16 \
    --out "docs/quality/atss/specular-$name"
done
