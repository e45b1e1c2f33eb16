#!/usr/bin/env bash
# Sets up (scripts/setup.sh) and runs every test on lavapipe with Vulkan validation on, synchronization
# validation included (a hazard the frame graph's barriers miss is a message; on lavapipe it costs
# about 5 % more time); any validation message fails the test that caused it. Images the tests make
# land in target/test-output/. SHUTTER_SYNC_VALIDATION=0 turns synchronization validation off.
#
# Two drivers: every test runs on the current lavapipe (Mesa 25.0, unpacked by setup.sh under
# .drivers/), then the tests that render run again on Debian 12's own (Mesa 22.3); the CPU-only unit
# tests of the engine run once. SHUTTER_TEST_DRIVERS="lavapipe-25.0" (a space-separated list) runs
# fewer; the first one listed runs everything.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export SHUTTER_VALIDATION=1
export SHUTTER_SYNC_VALIDATION="${SHUTTER_SYNC_VALIDATION:-1}"
# Lavapipe is the first-class target: pick it even on a machine with a GPU, unless told otherwise.
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
read -r -a drivers <<<"${SHUTTER_TEST_DRIVERS:-lavapipe-25.0 lavapipe-22.3}"
first=1
for driver in "${drivers[@]}"; do
  start=$SECONDS
  if ((first)); then
    echo "== every test on $driver"
    SHUTTER_DRIVER="$driver" cargo test --workspace --locked "$@"
    first=0
  else
    # The crates whose tests render: the integration tests and the command line's.
    echo "== the tests that render, on $driver"
    SHUTTER_DRIVER="$driver" cargo test --locked -p shutter-tests -p shutter-cli "$@"
  fi
  echo "== $driver: $((SECONDS - start)) s"
done
