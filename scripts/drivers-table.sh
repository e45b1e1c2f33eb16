#!/usr/bin/env bash
# What accuracy costs in time, per driver: `accumulation` against the stochastic frame (per-sample
# shading, the default) on three scenes, each against a 1,024-spp CPU reference, on every lavapipe the
# project runs on. Writes docs/quality/drivers/DRIVER/SCENE.{md,csv,png,svg} and the summary table
# docs/quality/drivers/summary.md (ms of accumulation ÷ ms of stochastic at equal FLIP, the range over
# the FLIP levels where both curves have points): the table at the head of docs/QUALITY.md.
# Usage: scripts/drivers-table.sh [DRIVER ...]   (default: lavapipe-25.0 lavapipe-22.3; after setup.sh)
# About 25 minutes on the 2-core VM; sweeps resume from their CSV (delete it to measure afresh).
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/drivers-common.sh
source scripts/drivers-common.sh
# scene, size, stochastic's S values (focus-sweep's 327,680-triangle sphere is slow to bound)
scenes=("default 160x90 4,16,64" "one-mover 160x90 4,16,64" "focus-sweep 96x54 4,16")
out=docs/quality/drivers
mkdir -p "$out"

# The range of the ratio column of the "ms of accumulation ÷ ms of stochastic" table of a quality report.
ratio_range() {
  awk '/^\*\*ms of `accumulation` ÷ ms of `stochastic` at equal FLIP/ {on=1; next}
       on && /^\| *[0-9]/ {gsub(/ /, ""); n=split($0, f, "|"); r=f[n-1]; if (min=="" || r<min) min=r; if (max=="" || r>max) max=r}
       on && /^$/ && min!="" {exit}
       END {if (min=="") print "no overlap"; else printf "%.2f–%.2f", min, max}' "$1"
}

for d in "${drivers[@]}"; do
  mkdir -p "$out/$d"
  for entry in "${scenes[@]}"; do
    read -r scene size sspp <<<"$entry"
    echo "== $d: $scene $size"
    $S --driver "$d" quality "$scene" --size "$size" --reference-spp 1024 \
      -s accumulation@4,16,64,256 -s "stochastic@$sspp" --frames 3 --warmup 1 \
      --out "$out/$d/$scene" >/dev/null
  done
done

{
  echo "ms of \`accumulation\` ÷ ms of \`stochastic\` (per-sample shading) at equal FLIP, the range over the"
  echo "FLIP levels both curves reach (\`scripts/drivers-table.sh\`; each cell's report, with its driver,"
  echo "CPU, commit and command, is \`docs/quality/drivers/DRIVER/SCENE.md\`):"
  echo
  printf "| scene (size) |"; for d in "${drivers[@]}"; do printf " %s |" "$d"; done; echo
  printf "|---|"; for d in "${drivers[@]}"; do printf -- "---:|"; done; echo
  for entry in "${scenes[@]}"; do
    read -r scene size _ <<<"$entry"
    printf "| \`%s\` (%s) |" "$scene" "${size/x/×}"
    for d in "${drivers[@]}"; do printf " %s |" "$(ratio_range "$out/$d/$scene.md")"; done
    echo
  done
} >"$out/summary.md"
cat "$out/summary.md"
