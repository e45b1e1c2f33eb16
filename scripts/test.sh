#!/usr/bin/env bash
# Sets up (scripts/setup.sh) and runs every test on lavapipe with Vulkan validation on, synchronization
# validation included (a hazard the frame graph's barriers miss is a message; on lavapipe it costs
# about 5 % more time); any validation message fails the test that caused it. Images the tests make
# land in target/test-output/. SHUTTER_SYNC_VALIDATION=0 turns synchronization validation off.
#
# Two drivers: every test runs on the current lavapipe (Mesa 25.0, unpacked by setup.sh under
# .drivers/), then again on Debian 12's own (Mesa 22.3). The second run is the same `cargo test
# --workspace`, so nothing is rebuilt: selecting only the crates whose tests render (-p shutter-tests
# -p shutter-cli) unifies dependency features differently and rebuilt for about 110 s, where the
# engine's CPU-only unit tests it repeats take about 13 s. SHUTTER_TEST_DRIVERS="lavapipe-25.0" (a
# space-separated list) runs fewer.
#
# The CPU reference does not depend on the driver, so the run keeps the references its tests trace in
# a folder of its own (SHUTTER_TEST_REFERENCE_CACHE, emptied when the run starts) and the second
# driver's pass reads them back instead of tracing them again. Set it yourself to keep a folder across
# runs (then it is not emptied; a change to the reference must bump REFERENCE_VERSION).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export SHUTTER_VALIDATION=1
# A CI machine builds once from an empty target folder: incremental compilation only costs there
# (the workspace's crates took 266 s with it, 216 s without, on the 2-core VM; docs/CI.md).
if [ "${CI:-}" = "true" ]; then export CARGO_INCREMENTAL="${CARGO_INCREMENTAL:-0}"; fi
export SHUTTER_SYNC_VALIDATION="${SHUTTER_SYNC_VALIDATION:-1}"
# Lavapipe is the first-class target: pick it even on a machine with a GPU, unless told otherwise.
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
# The library's documentation is part of its surface for porters: a broken intra-doc link or a
# malformed doc comment fails the run (no driver needed; about a minute after the build).
echo "== cargo doc (warnings are errors)"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --locked -p shutter
if [ -z "${SHUTTER_TEST_REFERENCE_CACHE:-}" ]; then
  export SHUTTER_TEST_REFERENCE_CACHE="$PWD/target/test-output/reference-cache"
  rm -rf "$SHUTTER_TEST_REFERENCE_CACHE"
fi
read -r -a drivers <<<"${SHUTTER_TEST_DRIVERS:-lavapipe-25.0 lavapipe-22.3}"
for driver in "${drivers[@]}"; do
  start=$SECONDS
  echo "== every test on $driver"
  SHUTTER_DRIVER="$driver" cargo test --workspace --locked "$@"
  echo "== $driver: $((SECONDS - start)) s"
done
