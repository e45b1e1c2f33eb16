#!/usr/bin/env bash
# The quality targets of `auto` measured (docs/QUALITY.md, "Quality targets"): for each of draft, good
# and final on the built-in `default` at its own size (640×360), the planner's choice (`shutter plan
# default --quality T`: technique, S, predicted GPU ms and FLIP), then one interleaved `shutter quality`
# run of every choice against today's `auto` at the scene's S = 16 (`auto@16`), against the CPU reference
# at 1024 spp (cached in out/cache). Needs a release build; writes docs/quality/targets-default.{md,csv}
# and the plot. About five minutes on the 2-core VM, most of it the reference on a cold cache.
set -euo pipefail
cd "$(dirname "$0")/.."
S=${SHUTTER:-target/release/shutter}
out=docs/quality
series=(-s "auto@16")
{
echo "| target | FLIP target | technique | S | predicted GPU ms | predicted FLIP |"
echo "|---|---:|---|---:|---:|---:|"
for t in draft good final; do
  line=$($S plan default --quality "$t" | grep '^quality ')
  tech=$(sed -n 's/.*): \([a-z]*\) at S = \([0-9]*\),.*/\1/p' <<< "$line")
  spp=$(sed -n 's/.*): \([a-z]*\) at S = \([0-9]*\),.*/\2/p' <<< "$line")
  ms=$(sed -n 's/.*predicted \([0-9.]*\) GPU ms.*/\1/p' <<< "$line")
  flip=$(sed -n 's/.*GPU ms, FLIP \([0-9.]*\).*/\1/p' <<< "$line")
  target=$(sed -n 's/.*(FLIP ≤ \([0-9.]*\)).*/\1/p' <<< "$line")
  echo "| $t | $target | $tech | $spp | $ms | $flip |"
  series+=(-s "$tech@$spp")
done
} > "$out/targets-default-plan.md"
cat "$out/targets-default-plan.md"
rm -f "$out/targets-default.csv"
$S quality default --size 640x360 --reference-spp 1024 --cache out/cache --frames 3 --warmup 1 "${series[@]}" \
  --out "$out/targets-default"
