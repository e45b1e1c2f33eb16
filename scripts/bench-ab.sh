#!/usr/bin/env bash
# A/B timing of two `shutter` binaries — e.g. the tree before and after a refactor — on the same
# machine: ROUNDS rounds, each running `shutter bench` with the old and the new binary (the order
# alternating between rounds, so drift hits both alike), then `shutter bench-compare` prints per
# configuration the median over runs of each run's median GPU ms and CPU frame ms, and new ÷ old.
#
# Usage: scripts/bench-ab.sh OLD_BIN NEW_BIN [ROUNDS] [MAX_RATIO]
#   e.g. build the old tree with `git worktree add /tmp/old <rev> && (cd /tmp/old && cargo build
#   --release --bin shutter)`, then scripts/bench-ab.sh /tmp/old/target/release/shutter
#   target/release/shutter 9 1.03
# What runs: SCENES (default: `default static`) × SETS, each set `WxH:config,config,...` benched as one
# interleaved run (default: the cheap forward techniques at 640x360, where a frame is long enough to
# time on a shared CPU, and `stochastic` at 160x90), S = SPP (4), FRAMES timed frames (7) after one
# warm-up frame. MAX_RATIO gates the process-CPU-time ratio by default (GATE=process|cpu|gpu|all): the
# CPU time of every thread of the process during a frame covers every pass in both binaries and is the
# steadiest measure on a shared machine (wall time swings by 10-20 % from run to run here), while the
# binaries' timestamp scopes may differ (the frame-graph port times the accumulator clear and the
# readback, which the tree before it left untimed). Both binaries must report process CPU time, which
# `shutter bench` does since the frame-graph port (docs/ARCHITECTURE.md says how the tree before it was
# measured).
# Reports land in out/ab/.
set -euo pipefail
cd "$(dirname "$0")/.."
OLD=$1
NEW=$2
ROUNDS=${3:-9}
MAX=${4:-}
SCENES=${SCENES:-"default static"}
SETS=${SETS:-"640x360:pinhole,accumulation 160x90:stochastic"}
SPP=${SPP:-4}
FRAMES=${FRAMES:-7}
GATE=${GATE:-process}
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
export SHUTTER_VALIDATION=0
mkdir -p out/ab
echo "== machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
"$NEW" probe > out/ab/probe.txt
head -2 out/ab/probe.txt
status=0
for scene in $SCENES; do
  for set in $SETS; do
    size=${set%%:*}
    configs=()
    IFS=, read -ra names <<< "${set#*:}"
    for c in "${names[@]}"; do configs+=(-c "$c"); done
    stem="out/ab/$scene-$size"
    rm -f "$stem"-old-*.json "$stem"-new-*.json
    for r in $(seq 1 "$ROUNDS"); do
      order="old new"
      if (( r % 2 == 0 )); then order="new old"; fi
      for who in $order; do
        bin=$OLD
        if [ "$who" = new ]; then bin=$NEW; fi
        "$bin" bench "$scene" --size "$size" --spp "$SPP" --frames "$FRAMES" --warmup 1 --no-counters \
          "${configs[@]}" --json "$stem-$who-$r.json" >/dev/null
      done
      echo "round $r of $scene $size done" >&2
    done
    args=()
    if [ -n "$MAX" ]; then args=(--max-ratio "$MAX" --gate "$GATE"); fi
    echo "### $scene, $size"
    "$NEW" bench-compare --old "$stem"-old-*.json --new "$stem"-new-*.json "${args[@]}" || status=1
  done
done
exit $status
