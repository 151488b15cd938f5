#!/usr/bin/env bash
# Installs every Debian 12 package Alphorn builds, tests or runs with. Idempotent: installs only
# what is missing, so the README commands are cheap to repeat. With --build, only what building
# the binaries needs (the Docker image's build stage), not the tools the tests drive.
set -euo pipefail
PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config python3 openssl git clang-format
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler libabsl-dev
  libopenexr-dev libeigen3-dev libgtest-dev libgmock-dev libbenchmark-dev
  libembree-dev libtbb-dev libpugixml-dev libtinyobjloader-dev libpng-dev zlib1g-dev
  libboost-dev libsqlite3-dev libzstd-dev libnanoflann-dev libpcg-cpp-dev libcli11-dev libssl-dev
  clang-14 libclang-rt-14-dev
  prometheus-cpp-dev
)
# Test and benchmark tools: a real Prometheus server scrapes a test farm; headless Chromium
# (through Selenium) drives the web dashboard; charts are drawn with matplotlib.
if [ "${1:-}" != "--build" ]; then
  PACKAGES+=(prometheus chromium chromium-driver python3-selenium python3-matplotlib python3-numpy)
  # docs/operations.md's backup steps (its test runs them).
  PACKAGES+=(sqlite3 rsync)
fi
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
