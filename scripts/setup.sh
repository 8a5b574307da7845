#!/usr/bin/env bash
# Installs TwoCam's build and run dependencies from Debian's packages. Idempotent: when every
# package is already installed it does nothing (no apt-get update, no network).
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libopencv-dev libmrpt-dev libceres-dev liboctomap-dev
  libcli11-dev libgtest-dev libgmock-dev googletest libbenchmark-dev nlohmann-json3-dev
  # The landmark store (src/store): SQLite 3 with its R*Tree module.
  libsqlite3-dev
  # Headless rendering: EGL with Mesa's software rasteriser (llvmpipe).
  libegl1 libegl-mesa0 libgl1-mesa-dri libgles2
  # Format and static checks (scripts/lint.sh), clang for the fuzz harnesses (tests/fuzz).
  clang-format clang-tidy clang
  # Plots from the CSV/JSON outputs.
  python3 python3-matplotlib python3-numpy
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "setup: need root (or sudo) to install: ${missing[*]}" >&2
    exit 1
  fi
fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
