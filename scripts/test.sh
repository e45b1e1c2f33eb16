#!/usr/bin/env bash
# Sets up (scripts/setup.sh) and runs every test on lavapipe with Vulkan validation on, synchronization
# validation included (a hazard the frame graph's barriers miss is a message; on lavapipe it costs
# about 5 % more time); any validation message fails the test that caused it. Images the tests make
# land in target/test-output/. SHUTTER_SYNC_VALIDATION=0 turns synchronization validation off.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export SHUTTER_VALIDATION=1
export SHUTTER_SYNC_VALIDATION="${SHUTTER_SYNC_VALIDATION:-1}"
# Lavapipe is the first-class target: pick it even on a machine with a GPU, unless told otherwise.
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
cargo test --workspace --locked "$@"
