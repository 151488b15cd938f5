#!/usr/bin/env bash
# The main job: installs what is missing, builds, and renders the Cornell box to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
tools/build.sh release
mkdir -p out
build/cli/alphorn render scenes/cbox/cbox.xml -o out/cbox.exr "$@"
echo "open out/cbox.png (or out/cbox.exr in an EXR viewer)"
