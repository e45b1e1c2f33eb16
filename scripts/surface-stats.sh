#!/usr/bin/env bash
# The numbers of docs/ARCHITECTURE.md's before/after table, for each commit given (default HEAD),
# each in a fresh git worktree with a fresh target directory, one after the other (run it on an
# otherwise idle machine: the build time is wall-clock):
#
#   build_s       clean `cargo build --release --locked -p shutter`: what a crate depending on
#                 Shutter compiles first (dependencies, build script, every shader permutation)
#   permutations  SPIR-V modules the build script compiled (one per permutation)
#   doc_pages     rustdoc pages of `shutter` (`cargo doc --no-deps`): its public items, modules included
#   largest_rs    the longest .rs file under engine/src, in lines
#   raw_cmd       raw `cmd_*` calls under engine/src/techniques
#
# Prints one tab-separated line per commit. Usage: scripts/surface-stats.sh [COMMIT ...]
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
[ $# -gt 0 ] || set -- HEAD
printf 'commit\tbuild_s\tpermutations\tdoc_pages\tlargest_rs\traw_cmd\n'
for commit in "$@"; do
  work=$(mktemp -d)
  git worktree add --detach -q "$work/tree" "$commit"
  # The unpacked drivers are not needed to build; the build needs nothing outside the tree.
  (
    cd "$work/tree"
    export CARGO_TARGET_DIR="$work/target"
    start=$(date +%s.%N)
    cargo build --release --locked -q -p shutter
    end=$(date +%s.%N)
    build_s=$(python3 -c "print(round($end - $start))")
    permutations=$(find "$CARGO_TARGET_DIR"/release/build/shutter-*/out -name '*.spv' | wc -l)
    cargo doc --no-deps --locked -q -p shutter 2>/dev/null
    doc_pages=$(find "$CARGO_TARGET_DIR/doc/shutter" -name '*.html' ! -name 'index.html' | wc -l)
    largest=$(find engine/src -name '*.rs' -exec wc -l {} + | grep -v ' total$' | sort -n | tail -1)
    raw_cmd=$(grep -rE '\.cmd_[a-z_]+\(' engine/src/techniques | wc -l)
    printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$(git rev-parse --short HEAD)" "$build_s" "$permutations" \
      "$doc_pages" "$(echo "$largest" | awk '{print $2 " " $1}')" "$raw_cmd"
  )
  git -C "$root" worktree remove --force "$work/tree"
  rm -rf "$work"
done
