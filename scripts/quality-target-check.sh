#!/usr/bin/env bash
# Does `shutter render --quality good` (the quality planner: technique and S chosen to reach a mean FLIP
# of 0.018 against the ground truth) meet its target? On `default` and `one-mover` (160×90) and
# `focus-sweep` (96×54), per driver: the planned render against a 1,024-spp CPU reference with another
# seed, printing the planner's choice, the measured FLIP and the verdict. Writes out/quality-QUALITY/.
# Usage: [QUALITY=draft|good|final] scripts/quality-target-check.sh [DRIVER ...]
#        (default: good; lavapipe-25.0 lavapipe-22.3)
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/drivers-common.sh
source scripts/drivers-common.sh
quality="${QUALITY:-good}"
case "$quality" in
  draft) target=0.04 ;;
  good) target=0.018 ;;
  final) target=0.01 ;;
  *) echo "QUALITY=$quality: draft, good or final" >&2; exit 2 ;;
esac
out=out/quality-$quality
mkdir -p "$out"
echo "| driver | scene | planned | measured FLIP | target met |"
echo "|---|---|---|---:|:---:|"
for entry in "default 160x90" "one-mover 160x90" "focus-sweep 96x54"; do
  read -r scene size <<<"$entry"
  ref="out/quality-reference/$scene-$size.exr"
  mkdir -p out/quality-reference
  [ -f "$ref" ] || $S reference "$scene" --size "$size" --spp 1024 --seed 7 --out "$ref" >/dev/null 2>&1
  for d in "${drivers[@]}"; do
    img="$out/$scene-$size-$d.exr"
    plan=$($S --driver "$d" render "$scene" --size "$size" --quality "$quality" --out "$img" 2>/dev/null \
      | sed -n "s/^auto: quality $quality (FLIP ≤ $target): \([a-z]* at S = [0-9]*\).*/\1/p")
    flip=$($S compare "$ref" "$img" | sed -n 's/.*FLIP *\([0-9.]*\).*/\1/p')
    met=$(awk -v f="$flip" -v t="$target" 'BEGIN { print (f <= t) ? "yes" : "NO" }')
    echo "| $d | \`$scene\` ($size) | $plan | $flip | $met |"
  done
done
