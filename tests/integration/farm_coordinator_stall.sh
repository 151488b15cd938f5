#!/usr/bin/env bash
# A coordinator frozen longer than a lease (SIGSTOP, as a paused VM is): when it runs again it
# sees the gap in its own clock and forgives it, so the healthy workers whose heartbeats it did
# not read are charged no failed attempt and keep their units; the job ends byte-identical.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --lease-seconds 2 --max-attempts 2
export ALPHORN_TEST_UNIT_DELAY_MS=400
start_worker a
start_worker b
unset ALPHORN_TEST_UNIT_DELAY_MS

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 8 --passes 6
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 8 --passes 6 --tile 32 2>/dev/null)
leased() { [[ $(job_field "$job" units_leased) -ge 1 ]]; }
wait_until 20 leased
kill -STOP "$COORDINATOR_PID"
sleep 5
kill -CONT "$COORDINATOR_PID"
"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the job did not finish after the stall"
[[ $(job_field "$job" attempts_failed) == 0 ]] ||
    fail "healthy workers were charged $(job_field "$job" attempts_failed) failed attempts for the coordinator's stall"
grep -q "event=coordinator.stalled" "$WORK/coordinator.log" || fail "no coordinator.stalled line"
"$ALPHORN" fetch "$job" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs from alphorn render"
pass "a 5 s stall of a coordinator with 2 s leases charged no attempt; EXR byte-identical"
echo "PASS"
