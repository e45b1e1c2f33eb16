#!/usr/bin/env bash
# Sets up (scripts/setup.sh), builds, and renders the embedded default scene (depth of field + motion
# blur) with the default technique `auto` to out/default-auto.png (pass e.g. `--technique accumulation`).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo run --release --locked --bin shutter -- render "$@"
