#!/usr/bin/env bash
# Farm benchmarks. Usage: bench/farm_bench.sh [BUILD_DIR] [SPP, default 32]
#  1. Farm overhead: the same job through `alphorn render --threads 1` and through a one-worker
#     farm (`alphorn cluster --workers 1 --threads 1 --render`), alternating, best of two each.
#     CPU time counts every process (client, coordinator, worker). Also checks the EXRs are equal.
#  2. Coordinator capacity: bench_farm_load with 200 simulated workers against a real coordinator.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
spp=${2:-32}
work=$(mktemp -d /tmp/alphorn-farm-bench-XXXXXX)
trap 'rm -rf "$work"' EXIT
scene=scenes/cbox/cbox.xml

measure() {  # prints "wall cpu" of a command, its own and its children's CPU
    /usr/bin/time -f "%e %U %S" -o "$work/time" "$@" >/dev/null 2>&1
    awk '{printf "%.3f %.3f\n", $1, $2 + $3}' "$work/time"
}
best_local=(1e9 1e9)
best_farm=(1e9 1e9)
for round in 1 2; do
    read -r wall cpu < <(measure "$build/cli/alphorn" render "$scene" --threads 1 --spp "$spp" --seed 1 -o "$work/local.exr")
    awk -v a="$wall" -v b="${best_local[0]}" 'BEGIN{exit !(a<b)}' && best_local=("$wall" "$cpu")
    read -r wall cpu < <(measure "$build/cli/alphorn" cluster --workers 1 --threads 1 --render "$scene" --spp "$spp" --seed 1 -o "$work/farm.exr")
    awk -v a="$wall" -v b="${best_farm[0]}" 'BEGIN{exit !(a<b)}' && best_farm=("$wall" "$cpu")
done
cmp "$work/local.exr" "$work/farm.exr" && identical=yes || identical=NO
echo "farm overhead ($scene, $spp spp, 1 thread): local ${best_local[0]} s wall ${best_local[1]} s CPU;" \
     "1-worker farm ${best_farm[0]} s wall ${best_farm[1]} s CPU;" \
     "ratio wall $(awk -v a="${best_farm[0]}" -v b="${best_local[0]}" 'BEGIN{printf "%.3f", a/b}')," \
     "CPU $(awk -v a="${best_farm[1]}" -v b="${best_local[1]}" 'BEGIN{printf "%.3f", a/b}'); EXRs identical: $identical"

openssl rand -hex 32 >"$work/client.token"
openssl rand -hex 32 >"$work/worker.token"
"$build/coordinator/alphorn-coordinator" --listen 127.0.0.1:0 --state-dir "$work/state" --port-file "$work/port" \
    --client-token-file "$work/client.token" --worker-token-file "$work/worker.token" --lease-seconds 60 \
    2>"$work/coordinator.log" &
coordinator=$!
for _ in $(seq 100); do [[ -s $work/port ]] && break; sleep 0.05; done
"$build/bench/bench_farm_load" "127.0.0.1:$(cat "$work/port")" "$work/client.token" "$work/worker.token" \
    bench/scenes/farm_load.xml 200 5 || true
kill "$coordinator"
wait "$coordinator" || true
