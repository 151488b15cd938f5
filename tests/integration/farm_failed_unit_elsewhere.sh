#!/usr/bin/env bash
# A worker killed on a unit (as the kernel's OOM killer does) restarts at once under a
# supervisor and asks for work while the other worker is busy: the unit that failed on its host
# goes to the other worker, not back to the restarted one, so the job completes instead of
# failing after --max-attempts (2 here) on one machine's trouble.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --lease-seconds 1 --max-attempts 2
LOOPS=()
# Worker a crashes on unit 1 of the job named "heavy", every time it renders it, and restarts on
# the same cache (the same host id), as systemd would restart it.
(
    child=""
    trap '[[ -n $child ]] && kill -9 $child 2>/dev/null; exit 0' TERM
    while :; do
        ALPHORN_TEST_CRASH_UNIT=heavy:1 "$WORKER" --coordinator "$ADDRESS" --token-file "$WORK/worker.token" \
            --cache-dir "$WORK/cache-a" --threads 1 --name a >>"$WORK/worker-a.log" 2>&1 &
        child=$!
        wait "$child" || true
        sleep 0.1
    done
) &
LOOPS+=($!)
trap 'for pid in "${LOOPS[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done; cleanup' EXIT
# Worker b is slow: it is busy when the crashed unit waits again, so only the restarted a asks.
export ALPHORN_TEST_UNIT_DELAY_MS=700
start_worker b
unset ALPHORN_TEST_UNIT_DELAY_MS

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 4 --passes 4
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --name heavy --seed 4 --passes 4 --tile 32 2>/dev/null)
"$ALPHORN" watch "$job" >/dev/null 2>&1 ||
    fail "the job failed: $("$ALPHORN" status "$job" --json | grep -o '"error":"[^"]*')"
"$ALPHORN" fetch "$job" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs from alphorn render"
grep -q "test_hook.crash" "$WORK/worker-a.log" || fail "worker a never crashed on the unit: the test tested nothing"
[[ $(grep -c "test_hook.crash" "$WORK/worker-a.log") == 1 ]] ||
    fail "the unit went back to the host it crashed on ($(grep -c test_hook.crash "$WORK/worker-a.log") crashes)"
pass "the unit that crashed worker a went to worker b; the job is byte-identical"
echo "PASS"
