#!/usr/bin/env bash
# Texture-space shading's time breakdown (the paper's table: pass 1 shade, pass 1 conservative, pass 2,
# the rest) and its shaded texels against the shading invocations of per-pixel and per-sample
# shading, on the built-in `arena` (one 93,696-triangle object) and `chess` (14 objects), at the
# paper's S = 4 and 8: one interleaved `shutter bench` per scene and S, with the counters' extra
# instrumented frame (docs/ATSS.md). Then the back-face culling ablation: the same at S = 4 with the
# scenes' one-sided materials made two-sided (nothing culled as back-facing; the images are the same).
# Needs a release build (cargo build --release); writes docs/quality/atss/breakdown-SCENE-sS.md and
# breakdown-SCENE-two-sided-s4.md.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shutter
mkdir -p docs/quality/atss
for scene in arena chess; do
  for spp in 4 8; do
    $S bench "$scene" --spp "$spp" --frames 3 --warmup 1 \
      -c stochastic:shading=per-sample -c stochastic:shading=per-pixel \
      -c stochastic:shading=texture-space -c stochastic:shading=texture-space-per-pixel \
      > "docs/quality/atss/breakdown-$scene-s$spp.md"
  done
done
mkdir -p out/atss
for scene in arena chess; do
  sed '/^one_sided = true$/d' "scenes/$scene.toml" > "out/atss/$scene-two-sided.toml"
  $S bench "out/atss/$scene-two-sided.toml" --spp 4 --frames 3 --warmup 1 \
    -c stochastic:shading=per-sample -c stochastic:shading=per-pixel \
    -c stochastic:shading=texture-space -c stochastic:shading=texture-space-per-pixel \
    > "docs/quality/atss/breakdown-$scene-two-sided-s4.md"
done
