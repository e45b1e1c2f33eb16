#!/usr/bin/env bash
# Installs what Shutter needs on Debian 12 (idempotent): Mesa lavapipe (software Vulkan), the Vulkan
# loader and validation layers, shaderc/glslang/SPIRV-Tools static libraries for build.rs, and a font
# for the plots of `shutter quality`.
# Also checks for a Rust toolchain. Run as root or with sudo available.
set -euo pipefail

PACKAGES=(mesa-vulkan-drivers libvulkan1 vulkan-validationlayers libshaderc-dev glslang-dev spirv-tools
          build-essential pkg-config fonts-dejavu-core)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]})); then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup: system packages present"
fi

if ! command -v cargo >/dev/null 2>&1; then
  if [ -x "$HOME/.cargo/bin/cargo" ]; then
    echo "setup: cargo is in ~/.cargo/bin; add it to PATH (source ~/.cargo/env)"
  else
    echo "setup: no Rust toolchain found; install one with rustup (https://rustup.rs) and rerun" >&2
    exit 1
  fi
fi

# Sanity: the static archives the .cargo/config.toml link override names must exist.
for lib in shaderc_combined glslang SPIRV SPIRV-Tools SPIRV-Tools-opt MachineIndependent; do
  [ -e "/usr/lib/x86_64-linux-gnu/lib$lib.a" ] || { echo "setup: missing lib$lib.a" >&2; exit 1; }
done
echo "setup: done"
