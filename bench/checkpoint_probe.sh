#!/bin/bash
# The coordinator's checkpoint cost on a large film: starts `alphorn cluster --workers 2` on the
# 960x540 stage (a 133 MB film), stops it after SECONDS, and prints the coordinator's CPU time
# and each `checkpoint.written` duration from its log. Compare two builds by running it with each
# directory of binaries in turn.
#
# usage: bench/checkpoint_probe.sh BINDIR [SECONDS] [LABEL]   (BINDIR holds alphorn,
#        alphorn-coordinator and alphorn-worker; run from the repository's top)
set -euo pipefail
bin=$1 seconds=${2:-75} label=${3:-$1}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$bin/alphorn" cluster --workers 2 --state-dir "$dir" --render scenes/stage/stage_seed.xml \
    --passes 64 -o "$dir/probe.exr" >/dev/null 2>&1 &
cli=$!
sleep "$seconds"
coordinator=$(pgrep -f "alphorn-coordinator .*$dir/state")
read -r user sys < <(awk '{print $14, $15}' "/proc/$coordinator/stat")
kill -INT "$cli"
wait "$cli" || true
ticks=$(getconf CLK_TCK)
awk -v l="$label" -v u="$user" -v s="$sys" -v t="$ticks" -v w="$seconds" \
    'BEGIN {printf "%s: coordinator CPU user %.2f s, sys %.2f s over %s s\n", l, u / t, s / t, w}'
grep checkpoint.written "$dir/coordinator.log" | sed 's/.*ms=//' |
    awk -v l="$label" '{s += $1; n++; a[n] = $1}
        END {printf "%s: %d checkpoints, mean %.0f ms:", l, n, n ? s / n : 0;
             for (i = 1; i <= n; i++) printf " %s", a[i]; print ""}'
