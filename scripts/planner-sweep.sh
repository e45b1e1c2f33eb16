#!/usr/bin/env bash
# The quality planner's promise over many seeds (issue 28 item 9; docs/QUALITY.md "Quality targets"):
# `shutter render --quality Q` (default good) for seeds FIRST..FIRST+SEEDS-1 (default 6..25, beyond
# the test's 1..5) on `one-mover` and on `static` with the sun casting shadows and a 0.05 aperture
# (the two scenes of tests/tests/quality_plan.rs), at SIZE (96x54), each render against the CPU
# reference at REF_SPP (2048) rays per pixel. Prints a markdown table (scene, seed, the plan's choice,
# its promise, the FLIP measured) and how many met the target. Files go to out/planner-sweep/.
set -euo pipefail
cd "$(dirname "$0")/.."
S=${SHUTTER:-target/release/shutter}
SIZE=${SIZE:-96x54}
FIRST=${FIRST:-6}
SEEDS=${SEEDS:-20}
REF_SPP=${REF_SPP:-2048}
Q=${QUALITY:-good}
dir=out/planner-sweep
mkdir -p "$dir"
# The sun-shadow scene as a file: static.toml, the sun casting shadows, a small lens.
sed -e 's/^aperture_radius = 0.0$/aperture_radius = 0.05/' -e '/^type = "directional"$/a shadows = true' \
  scenes/static.toml > "$dir/static-sun-shadows.toml"
echo "| scene | seed | choice | promised FLIP ≤ | FLIP against the reference | met |"
echo "|---|---:|---|---:|---:|:---:|"
met=0
total=0
for scene in one-mover "$dir/static-sun-shadows.toml"; do
  name=$(basename "$scene" .toml)
  ref="$dir/$name-reference.exr"
  [ -f "$ref" ] || $S reference "$scene" --size "$SIZE" --spp "$REF_SPP" --out "$ref" > /dev/null
  for ((seed = FIRST; seed < FIRST + SEEDS; seed++)); do
    img="$dir/$name-$seed.exr"
    log=$($S render "$scene" --size "$SIZE" --seed "$seed" --quality "$Q" --out "$img")
    choice=$(sed -n 's/^auto: quality [^:]*: \(.* at S = [0-9]*\)\(, shadow maps [0-9]*²\)\{0,1\},.*/\1\2/p' <<< "$log")
    promised=$(sed -n 's/.*promised FLIP ≤ \([0-9.]*\).*/\1/p' <<< "$log")
    target=$(sed -n 's/.*; target \([0-9.]*\).*/\1/p' <<< "$log")
    flip=$($S compare "$ref" "$img" | sed -n 's/.*FLIP \([0-9.]*\).*/\1/p')
    ok=$(awk -v f="$flip" -v t="$target" 'BEGIN { print (f <= t) ? "yes" : "no" }')
    [ "$ok" = yes ] && met=$((met + 1))
    total=$((total + 1))
    echo "| $name | $seed | $choice | $promised | $flip | $ok |"
  done
done
echo
echo "target $Q met in $met of $total renders"
