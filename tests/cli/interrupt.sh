#!/usr/bin/env bash
# Ctrl-C (SIGINT) during `alphorn render` writes the image of the passes completed, says so and
# exits 130; that image is byte-identical to a render of that many passes. --time-limit stops the
# same way and exits 0, and says so when a long pass took the render well past the limit.
# Usage: interrupt.sh ALPHORN SCENE
set -u
alphorn=$1
scene=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# passes_done LOG: K from "... after K of N passes: wrote ...".
passes_done() { sed -n 's/.* after \([0-9]*\) of [0-9]* passes: wrote .*/\1/p' "$1"; }

# Interrupted: started in the background with SIGINT not ignored (bash ignores it for background
# jobs unless job control is on), then interrupted once it has rendered a few passes.
set -m
"$alphorn" render "$scene" -o "$out/interrupted.exr" --passes 100000 --seed 5 --threads 2 \
  2>"$out/interrupted.log" &
pid=$!
set +m
for _ in $(seq 600); do
  grep -q '/100000 passes' "$out/interrupted.log" && break
  sleep 0.05
done
sleep 0.3
kill -INT "$pid"
timeout 60 tail --pid="$pid" -f /dev/null
wait "$pid"
status=$?
cat "$out/interrupted.log"
[ "$status" -eq 130 ] || fail "exit code $status after SIGINT, not 130"
grep -q "interrupted after [0-9]* of 100000 passes: wrote $out/interrupted.exr" "$out/interrupted.log" ||
  fail "no message saying the image of the passes done was written"
k=$(passes_done "$out/interrupted.log")
[ -n "$k" ] && [ "$k" -ge 1 ] || fail "cannot read the number of passes done"
timeout 120 "$alphorn" render "$scene" -o "$out/reference.exr" --passes "$k" --seed 5 2>/dev/null ||
  fail "the reference render failed"
cmp "$out/interrupted.exr" "$out/reference.exr" ||
  fail "the interrupted image differs from a render of $k passes"
echo "ok   SIGINT after $k passes: exit 130, image identical to --passes $k"

# A time limit.
timeout 120 "$alphorn" render "$scene" -o "$out/limited.exr" --passes 100000 --seed 5 --time-limit 1 \
  2>"$out/limited.log"
status=$?
cat "$out/limited.log"
[ "$status" -eq 0 ] || fail "exit code $status with --time-limit, not 0"
k=$(passes_done "$out/limited.log")
[ -n "$k" ] && [ "$k" -ge 1 ] && [ "$k" -lt 100000 ] || fail "cannot read the number of passes done"
grep -q "time limit reached after $k of 100000 passes" "$out/limited.log" || fail "no time limit message"
timeout 120 "$alphorn" render "$scene" -o "$out/reference.exr" --passes "$k" --seed 5 2>/dev/null ||
  fail "the reference render failed"
cmp "$out/limited.exr" "$out/reference.exr" || fail "the time-limited image differs from $k passes"
echo "ok   --time-limit 1 stopped after $k passes, image identical to --passes $k"

# A pass longer than the limit: finished first (whole passes only), and the message says so.
timeout 120 "$alphorn" render "$scene" -o "$out/long.exr" --passes 3 --size 1000x1000 --time-limit 0.01 \
  2>"$out/long.log"
status=$?
cat "$out/long.log"
[ "$status" -eq 0 ] || fail "exit code $status with --time-limit 0.01, not 0"
grep -q "time limit reached after 1 of 3 passes" "$out/long.log" || fail "no time limit message"
grep -q "note: the time limit (0.01 s) is looked at between passes; the pass running when it passed was finished first" \
  "$out/long.log" || fail "no note that the pass running at the limit was finished first"
echo "ok   a pass longer than --time-limit is finished first, and the message says so"
