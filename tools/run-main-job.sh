#!/usr/bin/env bash
# The main job: installs what is missing, builds, starts a local farm (a coordinator and two
# workers on loopback) and renders the Cornell box through it to out/. Extra arguments go to
# `alphorn cluster` (e.g. --passes 16, --workers 3, or --render OTHER.xml -o out/other.exr).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
tools/build.sh release
mkdir -p out
build/cli/alphorn cluster --workers 2 --render scenes/cbox/cbox.xml -o out/cbox.exr "$@"
echo "open out/cbox.png (or out/cbox.exr in an EXR viewer)"
