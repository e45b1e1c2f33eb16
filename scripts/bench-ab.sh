#!/usr/bin/env bash
# A/B timing of two `shutter` binaries — e.g. the tree before and after a refactor — on the same
# machine: ROUNDS rounds, each running `shutter bench` with the old and the new binary (the order
# alternating between rounds, so drift hits both alike), then `shutter bench-compare` prints per
# configuration the median over runs of each run's median GPU ms and CPU frame ms, and new ÷ old.
#
# Usage: scripts/bench-ab.sh OLD_BIN NEW_BIN [ROUNDS] [MAX_RATIO]
#   e.g. build the old tree with `git worktree add /tmp/old <rev> && (cd /tmp/old && cargo build
#   --release --bin shutter)`, then scripts/bench-ab.sh /tmp/old/target/release/shutter
#   target/release/shutter 5 1.03
# Scenes and configurations: pinhole, accumulation and stochastic on `default` and `static` at
# 160x90, S = 4 (override with SCENES / SIZE / SPP / FRAMES). Reports land in out/ab/.
set -euo pipefail
cd "$(dirname "$0")/.."
OLD=$1
NEW=$2
ROUNDS=${3:-5}
MAX=${4:-}
SCENES=${SCENES:-"default static"}
SIZE=${SIZE:-160x90}
SPP=${SPP:-4}
FRAMES=${FRAMES:-5}
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
export SHUTTER_VALIDATION=0
mkdir -p out/ab
echo "== machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
"$NEW" probe | head -2
status=0
for scene in $SCENES; do
  rm -f out/ab/"$scene"-old-*.json out/ab/"$scene"-new-*.json
  for r in $(seq 1 "$ROUNDS"); do
    order="old new"
    if (( r % 2 == 0 )); then order="new old"; fi
    for who in $order; do
      bin=$OLD
      if [ "$who" = new ]; then bin=$NEW; fi
      "$bin" bench "$scene" --size "$SIZE" --spp "$SPP" --frames "$FRAMES" --warmup 1 --no-counters \
        -c pinhole -c accumulation -c stochastic --json "out/ab/$scene-$who-$r.json" >/dev/null
      echo "round $r: $scene $who done"
    done
  done
  args=()
  if [ -n "$MAX" ]; then args=(--max-ratio "$MAX"); fi
  "$NEW" bench-compare --old out/ab/"$scene"-old-*.json --new out/ab/"$scene"-new-*.json "${args[@]}" || status=1
done
exit $status
