#!/usr/bin/env bash
# A longer chaos soak than CI's: runs tests/integration/farm_chaos.sh ROUNDS times with STEPS
# random actions each, a new seed per round (or SEED, SEED+1, ...), and stops at the first
# failure, printing the seed that replays it. Usage: tools/chaos-soak.sh [ROUNDS] [STEPS] [SEED]
# Needs a release build (tools/build.sh release).
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-20}
steps=${2:-40}
first_seed=${3:-$(($(date +%s) % 1000000))}
build=${BUILD_DIR:-build}
export ALPHORN=$PWD/$build/cli/alphorn COORDINATOR=$PWD/$build/coordinator/alphorn-coordinator
export WORKER=$PWD/$build/worker/alphorn-worker PROBE=$PWD/$build/tests/integration/alphorn_farm_probe
export SCENES=$PWD/tests/integration/scenes IO_FAULT=$PWD/$build/tests/support/libalphorn_io_fault.so
for ((round = 0; round < rounds; round++)); do
    seed=$((first_seed + round))
    log=$(mktemp /tmp/alphorn-chaos-soak-XXXXXX.log)
    start=$SECONDS
    if CHAOS_SEED=$seed CHAOS_STEPS=$steps bash tests/integration/farm_chaos.sh >"$log" 2>&1; then
        echo "round $((round + 1))/$rounds: seed $seed passed in $((SECONDS - start)) s"
        rm -f "$log"
    else
        echo "round $((round + 1))/$rounds: seed $seed FAILED; log: $log"
        grep -E "^(step|FAIL)" "$log" | tail -n 15
        echo "replay: CHAOS_SEED=$seed CHAOS_STEPS=$steps (with the variables above) bash tests/integration/farm_chaos.sh"
        exit 1
    fi
done
echo "soak passed: $rounds rounds x $steps steps from seed $first_seed"
