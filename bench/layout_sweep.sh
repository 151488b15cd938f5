#!/bin/bash
# The same render under different memory layouts: the output file's name, from 1 to N
# characters, moves where the heap puts everything allocated after it (Mytkowicz et al.,
# "Producing wrong data without doing anything obviously wrong!", ASPLOS 2009). A binary whose
# speed depends on layout (false sharing, aliasing) shows a wide spread of CPU times here; the
# binaries run interleaved, so machine load affects them alike.
#
#   bench/layout_sweep.sh ROUNDS MAX_NAME_LENGTH 'RENDER ARGUMENTS' BINARY...
#
# Prints one line per run (binary, name length, user+system CPU seconds, wall seconds) and, per
# binary, the minimum, median and maximum CPU time and the median of its CPU time over the first
# binary's in the same layout.
set -euo pipefail
if [ $# -lt 4 ]; then sed -n 2,12p "$0"; exit 2; fi
rounds=$1 longest=$2 arguments=$3
shift 3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for ((r = 0; r < rounds; r++)); do
    for ((length = 1; length <= longest; length++)); do
        name=$(printf 'n%.0s' $(seq "$length"))
        for binary in "$@"; do
            # shellcheck disable=SC2086
            /usr/bin/time -f "%U %S %e" -o "$work/time" "$binary" $arguments -o "$work/$name.exr" \
                >/dev/null 2>&1
            read -r user system wall <"$work/time"
            cpu=$(awk -v u="$user" -v s="$system" 'BEGIN { printf "%.2f", u + s }')
            echo "$binary $length $cpu $wall" | tee -a "$work/runs"
        done
    done
done
median() { sort -n | awk '{ v[NR] = $1 } END { printf "%.3f", (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
echo "binary: CPU seconds min / median / max over $((rounds * longest)) runs; median of the"
echo "per-layout CPU ratio to the first binary (the runs of one round and name length pair up)"
for binary in "$@"; do
    times=$(awk -v b="$binary" '$1 == b { print $3 }' "$work/runs")
    ratio=$(paste <(awk -v b="$1" '$1 == b { print $3 }' "$work/runs") <(echo "$times") |
        awk '{ print $2 / $1 }' | median)
    echo "$binary: $(echo "$times" | sort -n | head -1) / $(echo "$times" | median) /" \
        "$(echo "$times" | sort -n | tail -1); ratio $ratio"
done
