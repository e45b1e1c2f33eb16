#!/usr/bin/env bash
# The whole test suite with Vulkan synchronization validation on as well (SHUTTER_SYNC_VALIDATION=1):
# any hazard the frame graph's barriers miss is a validation message, and a validation message fails
# the test that caused it. Slower than scripts/test.sh (see docs/ARCHITECTURE.md for the time it took),
# so CI runs scripts/test.sh and this runs before a change to the graph or a technique lands.
set -euo pipefail
cd "$(dirname "$0")/.."
export SHUTTER_SYNC_VALIDATION=1
exec bash scripts/test.sh "$@"
