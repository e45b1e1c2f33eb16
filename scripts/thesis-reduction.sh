#!/usr/bin/env bash
# The thesis' mesh-reduction study (Toth & Linder, Figs. 19–21) on docs/scenes/thesis-sweep.toml: the
# statue (Spot, 5,856 triangles) reduced by meshoptimizer's simplifier (`simplify = F` in the scene file,
# Mesh::simplified) to F = 1, 1/2, 1/4, 1/8, 1/16 of its triangles, and per level:
#   * GPU ms per frame of stochastic rasterization at S = 16 and of accumulation at S = 64 (`shutter
#     quality`: median of --frames timed frames after --warmup, GPU timestamps; on lavapipe they are the
#     CPU's time running the driver);
#   * the image error (mean FLIP) of those two renders against the reference of the FULL mesh (the CPU
#     ray tracer, `shutter reference`) — what reducing the geometry costs in image quality — next to
#     their FLIP against the reduced mesh's own reference (the sampling error alone, from the CSV).
# The images compared are the last timed frames `shutter quality --images` saves (the very renders that
# were timed), not separate `shutter render` runs.
# Writes docs/quality/thesis/reduction.md (focus as stored; reduction-f30.md refocused) and the
# stochastic images at F = 1 and F = 1/16
# (docs/quality/thesis/reduction-1-stochastic-S16.png, reduction-0p0625-stochastic-S16.png: the
# fraction's dot spelled p in file names); scene variants, CSVs, images and the full
# reference go to out/thesis-reduction/, variant references to the quality cache out/cache/.
# About a minute on a 2-core machine with the defaults (the references at 1,024 spp take seconds each,
# the frames on lavapipe most of it). Settings can be overridden from the environment, e.g. a quick check:
#   REDUCTION_FRACTIONS="1 0.5" REDUCTION_REFERENCE_SPP=256 REDUCTION_FOCUS=stored bash scripts/thesis-reduction.sh
# REDUCTION_FOCUS lists the focus settings (default "stored 30": as stored, and refocused to 30).
# (a run with other settings than the defaults still writes reduction.md; its header says which).
# Usage: bash scripts/thesis-reduction.sh            (after scripts/setup.sh)
set -euo pipefail
cd "$(dirname "$0")/.."

read -r -a FRACTIONS <<<"${REDUCTION_FRACTIONS:-1 0.5 0.25 0.125 0.0625}"
SIZE="${REDUCTION_SIZE:-160x90}"
REF_SPP="${REDUCTION_REFERENCE_SPP:-1024}"
# Frames are cheap here (under 0.3 s each on lavapipe at 160x90) and a shared machine is noisy: 9 timed frames.
FRAMES="${REDUCTION_FRAMES:-9}"
WARMUP="${REDUCTION_WARMUP:-2}"
SCENE=docs/scenes/thesis-sweep.toml
WORK=out/thesis-reduction
DOCS=docs/quality/thesis
CACHE=out/cache

cargo build --release --locked --bin shutter
S=target/release/shutter
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
mkdir -p "$WORK" "$DOCS" "$CACHE"

grep -q '^mesh = "spot"$' "$SCENE" || { echo "no object with mesh = \"spot\" in $SCENE" >&2; exit 1; }
# The name of the object whose mesh is Spot (the row of `shutter plan` that counts its triangles).
STATUE=$(awk '/^\[\[object\]\]/ { name = "" } /^name = / { name = $3; gsub(/"/, "", name) }
  /^mesh = "spot"$/ { print name; exit }' "$SCENE")
[[ -n "$STATUE" ]] || { echo "the spot object in $SCENE has no name" >&2; exit 1; }

# One study per focus setting: the scene as stored (the statue in focus) and refocused on the
# buildings (the statue blurred by about 5.5 px at 160x90), where the thesis' argument says reduction
# should cost little image quality (detail below the circle of confusion is not resolved).
study() {
  local FOCUS=$1 BASE SUFFIX FOCUS_LABEL
  if [[ "$FOCUS" == stored ]]; then
    BASE=$SCENE SUFFIX="" FOCUS_LABEL="focus as stored, the statue sharp"
  else
    BASE="$WORK/thesis-sweep-f$FOCUS.toml" SUFFIX="-f${FOCUS//./p}" FOCUS_LABEL="focus distance $FOCUS"
    sed "s/^focus_distance = .*/focus_distance = $FOCUS/" "$SCENE" >"$BASE"
  fi
  echo "== the full mesh's reference: $SIZE, $REF_SPP spp"
  FULL_REF="$WORK/full-reference$SUFFIX-$SIZE-${REF_SPP}spp.exr"
  $S reference "$BASE" --size "$SIZE" --spp "$REF_SPP" --out "$FULL_REF"

  # Rows of the table, one per fraction.
  ROWS=()
  IMAGES=()
  DEVICE=""
  for F in "${FRACTIONS[@]}"; do
    echo "== simplify = $F"
    # The variant: the scene with `simplify = F` right after `mesh = "spot"` (the scene uses only
    # built-in meshes and textures, so it needs no relative paths and may live anywhere).
    TAG=${F//./p} # file names without the fraction's dot (`quality --out` replaces an extension)
    VARIANT="$WORK/thesis-sweep-reduction$SUFFIX-$TAG.toml"
    awk -v f="$F" '{ print } /^mesh = "spot"$/ { print "simplify = " f }' "$BASE" >"$VARIANT"
    TRIANGLES=$($S plan "$VARIANT" --size "$SIZE" | awk -F'|' -v n="$STATUE" \
      '{ gsub(/ /, "", $2); gsub(/ /, "", $3) } $2 == n { print $3; exit }')
    OUT="$WORK/reduction$SUFFIX-$TAG"
    rm -f "$OUT.csv" # fresh measurements (quality resumes from a CSV it finds)
    $S quality "$VARIANT" --size "$SIZE" --reference-spp "$REF_SPP" --cache "$CACHE" \
      -s stochastic@16 -s accumulation@64 --frames "$FRAMES" --warmup "$WARMUP" --images --out "$OUT"
    # CSV: ...,device (quoted, may hold commas),series,spp,gpu_ms_median,rmse,flip,passes,msaa — so the
    # fields are read from the end.
    field() { # series, field counted from the end (0 = msaa)
      awk -F, -v s="$1" -v k="$2" 'NR > 1 && $(NF - 6) == s { print $(NF - k) }' "$OUT.csv"
    }
    DEVICE=$(sed -n '2s/.*,"\([^"]*\)",.*/\1/p' "$OUT.csv")
    flip_full() { $S compare "$FULL_REF" "$1" | awk '$1 == "FLIP" { print $2 }'; }
    MS_STO=$(field stochastic 4)
    MS_ACC=$(field accumulation 4)
    OWN_STO=$(field stochastic 2)
    OWN_ACC=$(field accumulation 2)
    FULL_STO=$(flip_full "$OUT-stochastic-S16.png")
    FULL_ACC=$(flip_full "$OUT-accumulation-S64.png")
    ROWS+=("$(awk -v f="$F" -v t="$TRIANGLES" -v ms="$MS_STO" -v ma="$MS_ACC" -v fs="$FULL_STO" \
      -v fa="$FULL_ACC" -v os="$OWN_STO" -v oa="$OWN_ACC" 'BEGIN {
        printf "| %s | %s | %.1f | %.1f | %.2f | %.4f | %.4f | %.4f | %.4f |", f, t, ms, ma, ms / ma, fs, fa, os, oa }')")
    echo "${ROWS[-1]}"
    case "$F" in
      1 | 0.0625)
        cp "$OUT-stochastic-S16.png" "$DOCS/reduction$SUFFIX-$TAG-stochastic-S16.png"
        IMAGES+=("$F")
        ;;
    esac
  done

  {
    echo "# Mesh reduction on the thesis' sweep scene, $FOCUS_LABEL"
    echo
    echo "Generated by \`bash scripts/thesis-reduction.sh\`. Scene \`$SCENE\` ($FOCUS_LABEL) with \`simplify = F\` on the"
    echo "statue (Spot; meshoptimizer's simplifier, \`Mesh::simplified\`), $SIZE, on $DEVICE."
    echo "GPU ms = median of $FRAMES frame(s) after $WARMUP warm-up frame(s) (\`shutter quality\`). FLIP ="
    echo "mean FLIP of the last timed frame (saved as PNG) against the CPU reference at $REF_SPP spp of the"
    echo "**full** mesh (\`shutter reference\`, \`shutter compare\`): sampling error and the reduction's"
    echo "geometric error together. The last two columns are each render's FLIP against the reference of"
    echo "its own reduced mesh (\`shutter quality\`'s CSV): the sampling error alone."
    echo
    echo "| fraction | statue triangles | stochastic S=16 ms | accumulation S=64 ms | stochastic ÷ accumulation | FLIP stochastic 16 vs full | FLIP accumulation 64 vs full | FLIP stochastic 16 vs own | FLIP accumulation 64 vs own |"
    echo "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    printf '%s\n' "${ROWS[@]}"
    echo
    for F in "${IMAGES[@]}"; do
      echo "Stochastic S=16 at F = $F: ![stochastic 16, simplify $F](reduction$SUFFIX-${F//./p}-stochastic-S16.png)"
      echo
    done
  } >"$DOCS/reduction$SUFFIX.md"
  echo "wrote $DOCS/reduction$SUFFIX.md"
}

for FOCUS in ${REDUCTION_FOCUS:-stored 30}; do
  study "$FOCUS"
done
