#!/usr/bin/env bash
# Configures and builds one build tree. Usage: tools/build.sh [release|sanitize|fuzz]
# The sanitizer tree builds only the unit tests, which is what CI runs under ASan+UBSan; the fuzz
# tree builds only the libFuzzer harnesses (fuzz/), with clang, as tools/fuzz.sh runs them.
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-release}
jobs=$(nproc)
case "$kind" in
  release)  dir=build;          flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo); targets=(all) ;;
  sanitize) dir=build-sanitize; flags=(-DCMAKE_BUILD_TYPE=Debug -DALPHORN_SANITIZE=ON); targets=(alphorn_unit_tests) ;;
  fuzz)     dir=build-fuzz;     flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DALPHORN_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++-14); targets=(alphorn_fuzzers) ;;
  *) echo "unknown build kind: $kind" >&2; exit 2 ;;
esac
cmake -S . -B "$dir" -G Ninja -DALPHORN_WERROR=ON "${flags[@]}" >/dev/null
cmake --build "$dir" -j "$jobs" --target "${targets[@]}"
