#!/usr/bin/env bash
# 6b: kill -9 of one worker mid-job. Its lease expires, the unit is rendered again by the other
# worker, and the image is byte-identical to `alphorn render`; no unit is merged twice.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --lease-seconds 1
# Test hook: each unit takes this much longer. The victim sits 2 s in each unit, so it is killed
# while it holds a lease (killed between two units, it would leave no lease to expire: with a
# short delay that happened in ~3% of runs under load).
export ALPHORN_TEST_UNIT_DELAY_MS=2000
start_worker a
victim=$WORKER_PID
export ALPHORN_TEST_UNIT_DELAY_MS=120
start_worker b
survivor=$WORKER_PID
unset ALPHORN_TEST_UNIT_DELAY_MS

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 3 --passes 8
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 3 --passes 8 --tile 32 2>/dev/null)
victim_id=$(sed -n 's/.*event=worker.registered worker=\([0-9]*\) name=a .*/\1/p' "$WORK/coordinator.log" | head -n1)
[[ -n $victim_id ]] || fail "worker a did not register"
victim_leased() { grep -q "event=unit.leased job=$job unit=[0-9]* worker=$victim_id " "$WORK/coordinator.log"; }
units_done() { (($(job_field "$job" units_done) >= 3)); }
wait_until 30 victim_leased
wait_until 30 units_done
kill -9 "$victim"
pass "killed worker a (pid $victim) with $(job_field "$job" units_done) of $(job_field "$job" units_total) units merged"

"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the job did not finish after a worker died"
"$ALPHORN" fetch "$job" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs after a worker was killed"
pass "EXR byte-identical to alphorn render after kill -9 of a worker"
[[ $(job_field "$job" units_merged_this_run) == $(job_field "$job" units_total) ]] ||
    fail "units merged ($(job_field "$job" units_merged_this_run)) != units total"
# The killed worker held a unit of its own (its expiry is a failed attempt) or one it rendered
# again for an audit of another worker's result (audit.failed: not an attempt, that result is
# held); either way its lease expired.
grep -qE "event=(unit|audit).failed.*lease expired" "$WORK/coordinator.log" || fail "no lease-expiry log line"
if grep -q "event=unit.failed.*lease expired" "$WORK/coordinator.log"; then
    (($(job_field "$job" attempts_failed) >= 1)) || fail "the killed worker's expired lease was not counted (attempts_failed)"
fi
pass "the dead worker's unit was requeued after its lease expired; every unit merged exactly once"

# SIGTERM drains: the worker finishes and delivers the unit it holds, takes no more, exits 0.
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 3 --passes 8 --tile 32 2>/dev/null)
leased() { (($(job_field "$job" units_leased) >= 1)); }
wait_until 30 leased
kill -TERM "$survivor"
wait "$survivor" || fail "the worker did not exit 0 after SIGTERM"
grep -q "event=worker.drained" "$WORK/worker-b.log" || fail "the worker did not drain"
done_at_exit=$(job_field "$job" units_done)
((done_at_exit >= 1)) || fail "the draining worker did not deliver the unit it held"
[[ $(job_field "$job" units_leased) == 0 ]] || fail "the drained worker still holds a lease"
pass "SIGTERM: worker delivered its unit ($done_at_exit merged), exited 0"
start_worker c
"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the job did not finish with a fresh worker"
"$ALPHORN" fetch "$job" -o "$WORK/farm2.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm2.exr" || fail "the EXR differs after a drained worker"
pass "a fresh worker finished the job; EXR byte-identical"
echo "PASS"
