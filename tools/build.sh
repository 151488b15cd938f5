#!/usr/bin/env bash
# Configures and builds one build tree. Usage: tools/build.sh [release|sanitize]
# The sanitizer tree builds only the unit tests, which is what CI runs under ASan+UBSan.
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-release}
jobs=$(nproc)
case "$kind" in
  release)  dir=build;          flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo); targets=(all) ;;
  sanitize) dir=build-sanitize; flags=(-DCMAKE_BUILD_TYPE=Debug -DALPHORN_SANITIZE=ON); targets=(alphorn_unit_tests) ;;
  *) echo "unknown build kind: $kind" >&2; exit 2 ;;
esac
cmake -S . -B "$dir" -G Ninja -DALPHORN_WERROR=ON "${flags[@]}" >/dev/null
cmake --build "$dir" -j "$jobs" --target "${targets[@]}"
