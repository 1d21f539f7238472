#!/usr/bin/env bash
# Installs every Debian package saccade needs to build, test and run its demo.
# Idempotent: packages already present are left alone, and apt is only touched
# when something is missing. Needs root (or sudo) only in that case.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config ccache
  libopencv-dev opencv-doc
  libboost-dev
  libtinyxml2-dev
  libeigen3-dev
  libspdlog-dev libfmt-dev
  libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev nlohmann-json3-dev
  libfastrtps-dev libfastcdr-dev fastddsgen
  gstreamer1.0-tools gstreamer1.0-plugins-base
  openssl libssl-dev iproute2
  graphviz
  libzstd-dev liblz4-dev
  clang libclang-rt-14-dev
  clang-tidy clang-format
  chromium
)

# Node.js and npm run the tests' real clients (an MCAP reader, a Foxglove
# WebSocket client, a headless-browser driver): Debian's, unless a Node.js
# with its own npm is already there.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
