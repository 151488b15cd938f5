#!/usr/bin/env bash
# What audits cost the coordinator: bench_farm_load (simulated workers returning correctly
# shaped results without rendering, so every audit agrees) against the same coordinator with
# --audit 0 and with --audit FRACTION, taking turns round after round (bench/farm_lock_bench.sh).
# Each worker's first unit of the job is audited in both variants (that is not optional); the
# figure is what the share adds in the coordinator, beside the render time it adds on workers,
# which is the fraction itself.
# Usage: bench/audit_cost.sh BUILD_DIR SCENE.xml WORKERS PASSES ROUNDS [FRACTION]
set -euo pipefail
cd "$(dirname "$0")/.."
build=$1 scene=$2 workers=$3 passes=$4 rounds=$5 fraction=${6:-0.01}
wrappers=$(mktemp -d /tmp/alphorn-audit-bench-XXXXXX)
trap 'rm -rf "$wrappers"' EXIT
coordinator=$(realpath "$build/coordinator/alphorn-coordinator")
for audit in 0 "$fraction"; do
    printf '#!/bin/sh\nexec %s "$@" --audit %s\n' "$coordinator" "$audit" >"$wrappers/audit-$audit"
    chmod +x "$wrappers/audit-$audit"
done
bench/farm_lock_bench.sh "$build" "$scene" "$workers" "$passes" "$rounds" \
    "$wrappers/audit-0:0" "$wrappers/audit-$fraction:0"
