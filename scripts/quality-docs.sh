#!/usr/bin/env bash
# Regenerates docs/QUALITY.md's measurements (lavapipe unless SHUTTER_DEVICE says otherwise): the
# error-vs-time sweeps of `default` and `focus-sweep`, the planner benchmark and the hardware-feature
# experiments. Each block can be run on its own; sweeps resume from their CSV when interrupted (delete
# the CSV to measure afresh). About 40 minutes on a 2-core machine, most of it focus-sweep's
# 327,680-triangle sphere through the stochastic rasterizer.
# Usage: scripts/quality-docs.sh            (after scripts/setup.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
# The dev profile (Shutter at opt-level 1, dependencies at 3): GPU times are the driver's own and do not
# depend on it; CPU frame times include Shutter's recording, slightly slower than a release build.
cargo build --locked --bin shutter
S=target/debug/shutter
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

echo "== experiments: samples per pass, shading rate, GS vs compute hull"
$S bench default --size 320x180 --spp 16 -c stochastic -c stochastic:per-pass=4 \
  -c stochastic:shading=per-sample -c stochastic:hull=compute --frames 3 --warmup 1 \
  --json docs/quality/bench-experiments-default.json | tee docs/quality/bench-experiments-default.md
$S bench focus-sweep --size 96x54 --spp 4 -c stochastic -c stochastic:hull=compute -c auto \
  --frames 1 --warmup 1 --json docs/quality/bench-experiments-focus-sweep.json \
  | tee docs/quality/bench-experiments-focus-sweep.md

$S probe | tee docs/quality/probe.txt
