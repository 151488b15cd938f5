#!/usr/bin/env bash
# Every test: installs what is missing, builds a release tree and an ASan+UBSan tree, and runs
# all tests in the release tree and the unit tests in the sanitizer tree; in between, a short
# libFuzzer run of every input boundary (fixed seed and run counts, under 3 minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/alphorn-ccache}
# pcg_extras.hpp uses __TIME__ in code Alphorn never calls; without this ccache never reuses the
# objects that include it (and the docker test's image build reuses this cache).
export CCACHE_SLOPPINESS=${CCACHE_SLOPPINESS:-time_macros}
# Paths relative to the checkout (and no working directory in the hash), so every clone, CI's
# included, reuses the same cache entries.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD} CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-1}
tools/build.sh release
echo "== all tests (release build)"
ctest --test-dir build --output-on-failure -j "$(nproc)"
tools/fuzz.sh --smoke
tools/build.sh sanitize
echo "== unit tests under AddressSanitizer + UndefinedBehaviorSanitizer"
# The photon mapper's progressive convergence tests (many passes of the same code the other
# photon-mapper unit tests run under the sanitizers in well under a second) take about 2 minutes
# each under ASan even at -O1, against 1.5 s in the release tree, where they run; so do the
# t-tests of bdpt and vcm (VcmConvergence), whose code the other vcm tests run here; and the
# adaptive-passes t-test over seeds (AdaptiveConvergence), whose code ErrorEstimateAdaptive runs;
# and the error estimate's accuracy t-tests over seeds (ErrorEstimateAccuracy), whose arithmetic
# ErrorEstimate checks on hand-made films.
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-sanitize --output-on-failure -j "$(nproc)" -L unit \
  -E "ProgressiveConvergence[.]|VcmConvergence[.]|AdaptiveConvergence[.]|ErrorEstimateAccuracy[.]"
