#!/usr/bin/env bash
# 6d: a worker that comes back after its lease expired. The probe leases a unit and goes
# silent; the lease expires, real workers finish the job; then the probe heartbeats (told to
# drop the unit) and delivers a deliberately wrong film, which must be discarded: the image
# stays byte-identical and no unit is counted twice.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --lease-seconds 1
render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 4 --passes 4
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 4 --passes 4 --tile 32 2>/dev/null)

"$PROBE" late-result "$ADDRESS" "$WORK/worker.token" "$WORK/client.token" "$job" >"$WORK/probe.log" 2>&1 &
probe=$!
PIDS+=("$probe")
probe_ready() { grep -q READY "$WORK/probe.log"; }
wait_until 20 probe_ready
start_worker a
start_worker b
wait "$probe" || fail "late-result probe: $(cat "$WORK/probe.log")"
cat "$WORK/probe.log"

[[ $(job_field "$job" state) == JOB_STATE_DONE ]] || fail "the job is not done"
"$ALPHORN" fetch "$job" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the late result changed the image"
(($(job_field "$job" results_discarded) >= 1)) || fail "results_discarded should count the late result"
[[ $(job_field "$job" units_merged_this_run) == $(job_field "$job" units_total) ]] || fail "a unit was merged twice"
pass "late result dropped, no double counting, EXR byte-identical"
echo "PASS"
