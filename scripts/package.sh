#!/usr/bin/env bash
# The release archive a driver's CI runs `shutter check` from, without a Rust toolchain:
#   dist/shutter-VERSION-ARCH-linux.tar.gz
#     bin/shutter                      the release build (shaderc linked in statically)
#     share/shutter/check/             the suites and their expected images (`--suite smoke` finds them)
#     share/shutter/scenes/            the scene files the suites name (check/full.toml's hard cases)
#     share/doc/shutter/CI.md, README.md
# It needs at run time only the Vulkan loader (libvulkan.so.1) and the driver under test; the check's
# exact tier additionally needs the driver and CPU the images were recorded on (docs/CI.md).
# Builds with scripts/setup.sh's toolchain; `--no-setup` skips it (a machine already set up).
set -euo pipefail
cd "$(dirname "$0")/.."
[[ "${1:-}" == "--no-setup" ]] || bash scripts/setup.sh
[[ -f "$HOME/.cargo/env" ]] && source "$HOME/.cargo/env"
cargo build --release --locked -p shutter-cli
target_dir="${CARGO_TARGET_DIR:-target}"
version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
name="shutter-$version-$(uname -m)-linux"
stage="$target_dir/package/$name"
rm -rf "$stage" && mkdir -p "$stage/bin" "$stage/share/shutter" "$stage/share/doc/shutter" dist
cp "$target_dir/release/shutter" "$stage/bin/"
cp -r check scenes "$stage/share/shutter/"
cp docs/CI.md README.md "$stage/share/doc/shutter/"
# Reproducible: sorted names, fixed owner and time (the commit's).
when=$(git log -1 --format=%ct 2>/dev/null || echo 0)
tar --sort=name --owner=0 --group=0 --numeric-owner --mtime="@$when" -C "$target_dir/package" -czf "dist/$name.tar.gz" "$name"
sha256sum "dist/$name.tar.gz" | tee "dist/$name.tar.gz.sha256"
# Smoke-test the archive where it lands, away from the source tree: its own binary finds its suites.
tmp=$(mktemp -d) && trap 'rm -rf "$tmp"' EXIT
tar -xzf "dist/$name.tar.gz" -C "$tmp"
(cd "$tmp" && "./$name/bin/shutter" check --suite smoke --only pinhole --out "$tmp/out")
echo "package: dist/$name.tar.gz"
