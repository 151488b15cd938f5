#!/usr/bin/env bash
# The coordinator's lock under load: bench_farm_load against coordinator binaries taking turns,
# round after round, each run on a fresh state directory, so that the machine's load drifts
# alike over every variant. A variant is BINARY:CLIENT_CALLS_PER_SECOND.
# Usage: [TILE_SIZE=N [PREVIEW_FORMAT=film|png]] bench/farm_lock_bench.sh BUILD_DIR SCENE.xml WORKERS PASSES ROUNDS VARIANT...
# (TILE_SIZE: the job's tile size, 1 unless set; PREVIEW_FORMAT: film unless set; see
# bench_farm_load.)
# Prints each run's bench_farm_load lines and the coordinator's CPU time prefixed by the variant,
# then per variant the medians over the rounds of the coordinator's CPU time, the lease and
# result p99 and the units per second, and their ratios to the first variant's.
set -euo pipefail
cd "$(dirname "$0")/.."
build=$1 scene=$2 workers=$3 passes=$4 rounds=$5
shift 5
variants=("$@")
work=$(mktemp -d /tmp/alphorn-lock-bench-XXXXXX)
coordinator=
cleanup() {
    [[ -n $coordinator ]] && kill "$coordinator" 2>/dev/null && wait "$coordinator" 2>/dev/null
    rm -rf "$work"
}
trap cleanup EXIT
openssl rand -hex 32 >"$work/client.token"
openssl rand -hex 32 >"$work/worker.token"
chmod 600 "$work"/*.token
for round in $(seq "$rounds"); do
    # Odd rounds in the order given, even rounds reversed.
    order=("${variants[@]}")
    if ((round % 2 == 0)); then
        order=()
        for ((i = ${#variants[@]} - 1; i >= 0; --i)); do order+=("${variants[i]}"); done
    fi
    for variant in "${order[@]}"; do
        binary=${variant%:*} calls=${variant##*:}
        rm -rf "$work/state" "$work/port"
        "$binary" --listen 127.0.0.1:0 --state-dir "$work/state" --port-file "$work/port" \
            --client-token-file "$work/client.token" --worker-token-file "$work/worker.token" \
            --lease-seconds 60 2>"$work/coordinator.log" &
        coordinator=$!
        for _ in $(seq 100); do [[ -s $work/port ]] && break; sleep 0.05; done
        "$build/bench/bench_farm_load" "127.0.0.1:$(cat "$work/port")" "$work/client.token" \
            "$work/worker.token" "$scene" "$workers" "$passes" "$calls" "${TILE_SIZE:-1}" "${PREVIEW_FORMAT:-film}" |
            sed "s|^|$variant round $round: |" | tee -a "$work/results"
        # The coordinator's own CPU time over the run (utime + stime, clock ticks).
        cpu=$(awk -v hz="$(getconf CLK_TCK)" '{printf "%.2f", ($14 + $15) / hz}' "/proc/$coordinator/stat")
        echo "$variant round $round: coordinator CPU $cpu s" | tee -a "$work/results"
        kill "$coordinator"
        wait "$coordinator" || true
        coordinator=
    done
done
python3 - "$work/results" "${variants[@]}" <<'SUMMARY'
import re, statistics, sys
lines = open(sys.argv[1]).read().splitlines()
pattern = re.compile(r"([0-9.]+) units/s; lease latency p50 [0-9.]+ ms, p99 ([0-9.]+) ms; "
                     r"result latency p50 [0-9.]+ ms, p99 ([0-9.]+) ms")
medians = {}
cpu_pattern = re.compile(r"coordinator CPU ([0-9.]+) s")
for variant in sys.argv[2:]:
    cpus = [float(cpu_pattern.search(line).group(1)) for line in lines
            if line.startswith(variant + " round") and cpu_pattern.search(line)]
    if cpus:
        print("%s: coordinator CPU median %.2f s" % (variant, statistics.median(cpus)))
    runs = [pattern.search(line).groups() for line in lines
            if line.startswith(variant + " round") and pattern.search(line)]
    columns = [statistics.median(float(run[i]) for run in runs) for i in range(3)]
    medians[variant] = columns
    print("%s: median of %d runs: %.0f units/s, lease p99 %.2f ms, result p99 %.2f ms"
          % (variant, len(runs), *columns))
first = sys.argv[2]
for variant in sys.argv[3:]:
    print("%s / %s: units/s %.3f, lease p99 %.3f, result p99 %.3f" % (
        variant, first, *(medians[variant][i] / medians[first][i] for i in range(3))))
SUMMARY
