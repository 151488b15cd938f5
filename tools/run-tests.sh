#!/usr/bin/env bash
# Every test: installs what is missing, builds a release tree and an ASan+UBSan tree, and runs
# all tests in the release tree and the unit tests in the sanitizer tree.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/alphorn-ccache}
tools/build.sh release
echo "== all tests (release build)"
ctest --test-dir build --output-on-failure -j "$(nproc)"
tools/build.sh sanitize
echo "== unit tests under AddressSanitizer + UndefinedBehaviorSanitizer"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-sanitize --output-on-failure -j "$(nproc)" -L unit
