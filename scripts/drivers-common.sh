# Sourced by the per-driver scripts (drivers-table.sh, quality-target-check.sh) after `cd` to the
# checkout: S, the shutter binary (SHUTTER_BIN, e.g. a copy while the tree changes, else a fresh dev
# build), and drivers, the script's arguments or both lavapipes.
if [ -n "${SHUTTER_BIN:-}" ]; then S="$SHUTTER_BIN"; else cargo build --locked --bin shutter; S=target/debug/shutter; fi
export SHUTTER_DEVICE="${SHUTTER_DEVICE:-llvmpipe}"
drivers=("$@")
((${#drivers[@]})) || drivers=(lavapipe-25.0 lavapipe-22.3)
