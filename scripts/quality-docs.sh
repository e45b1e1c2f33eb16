#!/usr/bin/env bash
# Regenerates docs/QUALITY.md's measurements (lavapipe unless SHUTTER_DEVICE says otherwise): the
# error-vs-time sweeps of `default` and `focus-sweep`, the planner benchmark and the hardware-feature
# experiments. Each block can be run on its own; sweeps resume from their CSV when interrupted (delete
# the CSV to measure afresh). About 40 minutes on a 2-core machine, most of it focus-sweep's
# 327,680-triangle sphere through the stochastic rasterizer.
# Usage: scripts/quality-docs.sh            (after scripts/setup.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --bin shutter
S=target/release/shutter
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
mkdir -p docs/quality out

echo "== what accuracy costs in time: default, 160x90, reference 4096 spp"
$S quality default --size 160x90 --reference-spp 4096 \
  -s accumulation@4,16,64,256,1024 -s stochastic@4,16,64 -s stochastic:shading=per-sample@4,16,64 \
  -s auto@4,16,64 --frames 3 --warmup 1 --images --out docs/quality/default

echo "== what accuracy costs in time: focus-sweep, 96x54, reference 4096 spp (one frame per point)"
$S quality focus-sweep --size 96x54 --reference-spp 4096 \
  -s accumulation@4,16,64,256,1024 -s stochastic@4,16 -s stochastic:shading=per-sample@4,16 \
  -s auto@4,16 --frames 1 --warmup 0 --images --out docs/quality/focus-sweep

echo "== the planner: auto on static costs what pinhole costs (fails above 1.05x)"
$S bench static -c pinhole -c auto --frames 30 --warmup 3 --max-ratio 1.05 \
  --json docs/quality/bench-static.json --csv docs/quality/bench-static.csv | tee docs/quality/bench-static.md

echo "== the planner on one-mover: blur paid only where it is"
$S bench one-mover --size 320x180 --spp 16 -c pinhole -c auto -c stochastic --frames 5 --warmup 1 \
  --json docs/quality/bench-one-mover.json | tee docs/quality/bench-one-mover.md

echo "== hardware experiments: MSAA per pass, mask loop vs sample-rate shading"
$S bench default --size 320x180 --spp 16 -c stochastic -c stochastic:msaa=1 -c stochastic:msaa=2 \
  -c stochastic:shading=per-sample -c stochastic:msaa=1:shading=per-sample --frames 3 --warmup 1 \
  --json docs/quality/bench-msaa-shading.json | tee docs/quality/bench-msaa-shading.md

$S probe | tee docs/quality/probe.txt
