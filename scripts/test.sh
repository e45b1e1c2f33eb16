#!/usr/bin/env bash
# Sets up (scripts/setup.sh) and runs every test on lavapipe with Vulkan validation on; any validation
# message fails the test that caused it. Images the tests make land in target/test-output/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export SHUTTER_VALIDATION=1
# Lavapipe is the first-class target: pick it even on a machine with a GPU, unless told otherwise.
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
cargo test --workspace --locked "$@"
