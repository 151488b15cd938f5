#!/usr/bin/env bash
# `alphorn test` samples in parallel; its statistics must not depend on the thread count.
# Usage: test_determinism.sh ALPHORN FILE...
set -eu
alphorn=$1
shift
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for threads in 1 2; do
  # Drop the timings, which are the only thing allowed to differ.
  timeout 250 "$alphorn" test --threads "$threads" "$@" 2>&1 | sed 's/([0-9.]* s)//' >"$out/$threads.txt" ||
    true  # a failing statistical test is reported by its own ctest; here only equality counts
done
grep -q 'PASS\|FAIL' "$out/1.txt" || { cat "$out/1.txt"; echo "FAIL: no test results"; exit 1; }
if ! cmp -s "$out/1.txt" "$out/2.txt"; then
  diff "$out/1.txt" "$out/2.txt" | head -20
  echo "FAIL: results differ between --threads 1 and --threads 2"
  exit 1
fi
echo "OK: identical results with 1 and 2 threads"
