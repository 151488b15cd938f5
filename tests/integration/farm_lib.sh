# Shared helpers of the farm integration tests: real alphorn-coordinator and alphorn-worker
# processes on 127.0.0.1 with ephemeral ports, a private temporary directory, and cleanup of
# every process a test started. Sourced by farm_*.sh; CMake passes the binaries' paths.
set -euo pipefail

: "${ALPHORN:?}" "${COORDINATOR:?}" "${WORKER:?}" "${PROBE:?}" "${SCENES:?}"
WORK=$(mktemp -d /tmp/alphorn-farm-test-XXXXXX)
PIDS=()
COORDINATOR_PID=""
ADDRESS=""

cleanup() {
    local status=$?
    for pid in "${PIDS[@]}"; do kill -9 "$pid" 2>/dev/null || true; done
    wait 2>/dev/null || true
    if [[ $status -ne 0 ]]; then
        echo "---- test failed (status $status); logs in $WORK:"
        for log in "$WORK"/*.log; do [[ -f $log ]] && { echo "== $log"; tail -n 25 "$log"; }; done
    else
        rm -rf "$WORK"
    fi
}
trap cleanup EXIT

fail() { echo "FAIL: $*" >&2; exit 1; }
pass() { echo "ok   $*"; }

openssl rand -hex 32 >"$WORK/client.token" 2>/dev/null || head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' >"$WORK/client.token"
openssl rand -hex 32 >"$WORK/worker.token" 2>/dev/null || head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' >"$WORK/worker.token"
export ALPHORN_TOKEN_FILE="$WORK/client.token"

# start_coordinator [LISTEN [extra flags...]]: starts (or restarts) the coordinator on
# $WORK/state and waits until it listens; sets COORDINATOR_PID, PORT and ADDRESS.
start_coordinator() {
    local listen=${1:-127.0.0.1:0}
    shift || true
    rm -f "$WORK/port"
    "$COORDINATOR" --listen "$listen" --state-dir "$WORK/state" --client-token-file "$WORK/client.token" \
        --worker-token-file "$WORK/worker.token" --port-file "$WORK/port" "$@" >>"$WORK/coordinator.log" 2>&1 &
    COORDINATOR_PID=$!
    PIDS+=("$COORDINATOR_PID")
    for _ in $(seq 300); do
        [[ -s $WORK/port ]] && break
        kill -0 "$COORDINATOR_PID" 2>/dev/null || fail "the coordinator exited at start"
        sleep 0.05
    done
    [[ -s $WORK/port ]] || fail "the coordinator did not start listening"
    PORT=$(cat "$WORK/port")
    ADDRESS=${ADDRESS_HOST:-127.0.0.1}:$PORT
    export ALPHORN_COORDINATOR=$ADDRESS
}

# start_worker NAME [extra flags...]: a worker with one render thread; its pid is in WORKER_PID.
start_worker() {
    local name=$1
    shift
    "$WORKER" --coordinator "$ADDRESS" --token-file "$WORK/worker.token" --cache-dir "$WORK/cache-$name" \
        --threads 1 --name "$name" "$@" >>"$WORK/worker-$name.log" 2>&1 &
    WORKER_PID=$!
    PIDS+=("$WORKER_PID")
}

# job_field JOB FIELD: one field of `alphorn status JOB --json` (numbers and enum names).
job_field() {
    "$ALPHORN" status "$1" --json | grep -o "\"$2\":[^,}]*" | head -n1 | cut -d: -f2 | tr -d '"'
}

# wait_until TIMEOUT_SECONDS COMMAND...: polls until the command succeeds.
wait_until() {
    local timeout=$1
    shift
    local deadline=$((SECONDS + timeout))
    until "$@"; do
        ((SECONDS < deadline)) || fail "timed out waiting for: $*"
        sleep 0.1
    done
}

# render_local SCENE OUT [flags...]: the reference image from `alphorn render`.
render_local() {
    local scene=$1 out=$2
    shift 2
    "$ALPHORN" render "$scene" -o "$out" "$@" >>"$WORK/local.log" 2>&1
}
