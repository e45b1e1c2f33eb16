#!/usr/bin/env bash
# Installs what Shutter needs on Debian 12 (idempotent): Mesa lavapipe (software Vulkan, Debian 12's
# 22.3 from apt, and the current 25.0 unpacked under .drivers/), the Vulkan loader and validation layers, shaderc/glslang/SPIRV-Tools static libraries for build.rs, and a font
# for the plots of `shutter quality`.
# Also checks for a Rust toolchain. Run as root or with sudo available.
set -euo pipefail

PACKAGES=(mesa-vulkan-drivers libvulkan1 vulkan-validationlayers libshaderc-dev glslang-dev spirv-tools
          build-essential pkg-config fonts-dejavu-core curl ca-certificates)

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

# The current lavapipe beside Debian 12's: Mesa's lavapipe from bookworm-backports, unpacked under
# .drivers/ (ignored by git) without installing it, so the system's driver and apt configuration stay
# as they are. Shutter loads it in-process (engine/src/vk/drivers.rs); `shutter probe --all` lists
# both. Pinned by version and SHA-256; to move to a newer one, change the three lines below.
LVP_VERSION="25.0.7-2~bpo12+1"
LVP_FOLDER="lavapipe-25.0.7"
LVP_SHA256="3899f1800424c60a05df5d6913076a526ca8fdbabec43672cd397563d1ca3263"
LVP_URL="http://deb.debian.org/debian/pool/main/m/mesa/mesa-vulkan-drivers_${LVP_VERSION//\~/%7E}_amd64.deb"
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
LVP_DIR="$ROOT/.drivers/$LVP_FOLDER"
if [ "${SHUTTER_SKIP_DRIVERS:-0}" = "1" ]; then
  echo "setup: SHUTTER_SKIP_DRIVERS=1, not providing $LVP_FOLDER"
elif [ -f "$LVP_DIR/icd.json" ] && [ "$(cat "$LVP_DIR/.sha256" 2>/dev/null)" = "$LVP_SHA256" ]; then
  echo "setup: $LVP_FOLDER present"
else
  echo "setup: providing $LVP_FOLDER (mesa-vulkan-drivers $LVP_VERSION, unpacked, not installed)"
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  deb="$tmp/mesa-vulkan-drivers.deb"
  fetched=0
  for attempt in 1 2 3; do
    if curl -fsSL --retry 2 -o "$deb" "$LVP_URL" 2>"$tmp/curl.log" \
       || wget -q -O "$deb" "$LVP_URL" 2>>"$tmp/curl.log"; then
      fetched=1; break
    fi
    sleep $((attempt * 2))
  done
  if [ "$fetched" != 1 ]; then
    echo "setup: could not download $LVP_URL ($(tail -1 "$tmp/curl.log")); if Debian has moved" >&2
    echo "setup: bookworm-backports on, pin the new version in scripts/setup.sh" >&2
    exit 1
  fi
  got="$(sha256sum "$deb" | cut -d' ' -f1)"
  if [ "$got" != "$LVP_SHA256" ]; then
    echo "setup: $LVP_URL has SHA-256 $got, expected $LVP_SHA256; refusing it" >&2
    exit 1
  fi
  rm -rf "$LVP_DIR" && mkdir -p "$tmp/x" "$LVP_DIR"
  dpkg -x "$deb" "$tmp/x"
  cp "$tmp/x/usr/lib/x86_64-linux-gnu/libvulkan_lvp.so" "$LVP_DIR/"
  cat >"$LVP_DIR/icd.json" <<JSON
{
    "file_format_version": "1.0.0",
    "ICD": {
        "library_path": "$LVP_DIR/libvulkan_lvp.so",
        "api_version": "1.4.305"
    }
}
JSON
  echo "mesa-vulkan-drivers $LVP_VERSION from $LVP_URL" >"$LVP_DIR/SOURCE"
  echo "$LVP_SHA256" >"$LVP_DIR/.sha256"
  rm -rf "$tmp"; trap - EXIT
fi

# Sanity: the static archives the .cargo/config.toml link override names must exist.
for lib in shaderc_combined glslang SPIRV SPIRV-Tools SPIRV-Tools-opt MachineIndependent; do
  [ -e "/usr/lib/x86_64-linux-gnu/lib$lib.a" ] || { echo "setup: missing lib$lib.a" >&2; exit 1; }
done
echo "setup: done"
