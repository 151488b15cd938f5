#!/usr/bin/env bash
# A long soak of the coordinator simulation (coordinator/simulation_test.cpp): SEEDS seeds of
# STEPS steps each from FIRST_SEED (default: a new one from the clock), stopping at the first
# failure, which prints its seed and the command that replays it.
# Usage: tools/simulation-soak.sh [SEEDS] [STEPS] [FIRST_SEED]. Needs a release build.
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=${1:-100000}
steps=${2:-400}
first_seed=${3:-$(($(date +%s) * 1000))}
simulation=${BUILD_DIR:-build}/coordinator/alphorn_coordinator_simulation
echo "simulation soak: $seeds seeds x $steps steps from seed $first_seed"
exec "$simulation" --seeds "$seeds" --steps "$steps" --first-seed "$first_seed"
