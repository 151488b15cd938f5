#!/usr/bin/env bash
# A worker whose renderer is wrong joins a farm of two good workers (the test hook
# ALPHORN_TEST_PERTURB_RESULTS=1 adds one unit of red to a pixel of each film it renders, as a bad
# build, a damaged scene file or faulty memory would): the audit of its first unit catches it, a
# third render decides against it, it is quarantined and leased nothing more, and every job ends
# with the bytes of `alphorn render`. Also: each job's last unit.merged line comes before its
# job.ended line.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0
export ALPHORN_TEST_PERTURB_RESULTS=1
start_worker bad
bad_pid=$WORKER_PID
unset ALPHORN_TEST_PERTURB_RESULTS
start_worker good1
start_worker good2

render_local "$SCENES/farm_area_light.xml" "$WORK/local.exr" --seed 5 --passes 4
quarantined() { "$ALPHORN" workers --all --json | grep -o '"name":"bad"[^}]*' | grep -q '"quarantined":"[^"]'; }
# The bad worker's first unit, or its first audit of another's, gives it away; a job is short
# and the three workers race for units, so up to three jobs are submitted until it is caught.
for attempt in 1 2 3; do
    "$ALPHORN" submit "$SCENES/farm_area_light.xml" --seed 5 --passes 4 --tile 24 \
        -o "$WORK/farm$attempt.exr" 2>"$WORK/submit$attempt.log" ||
        fail "job $attempt failed: $(cat "$WORK/submit$attempt.log")"
    cmp "$WORK/local.exr" "$WORK/farm$attempt.exr" ||
        fail "job $attempt's EXR differs from alphorn render: a wrong worker's pixels were merged"
    quarantined && break
done
quarantined || fail "the wrong worker was not quarantined after three jobs: $("$ALPHORN" workers --all)"
pass "the wrong worker was caught by an audit and quarantined; every job is byte-identical"
grep -q "event=worker.quarantined worker=[0-9]* name=bad " "$WORK/coordinator.log" ||
    fail "no worker.quarantined line naming the bad worker"
grep -q "event=audit.agreed" "$WORK/coordinator.log" || fail "no audit.agreed line"
"$ALPHORN" workers --all | grep -q "quarantined: its render of unit" ||
    fail "alphorn workers does not say why the worker is quarantined: $("$ALPHORN" workers --all)"
"$ALPHORN" status --json | grep -q '"units_audited":[1-9]' || fail "no job counts an audited unit"
pass "the log, alphorn workers and status say what the audits found"

# Quarantined: the bad worker (still running) is given nothing, and says why.
merged_before=$("$ALPHORN" workers --all --json | grep -o '"name":"bad"[^}]*' | grep -o '"units_merged":"[0-9]*"' | grep -o '[0-9]*' || echo 0)
"$ALPHORN" submit "$SCENES/farm_area_light.xml" --seed 5 --passes 4 --tile 24 \
    -o "$WORK/after.exr" 2>/dev/null || fail "the job after the quarantine failed"
cmp "$WORK/local.exr" "$WORK/after.exr" || fail "the job after the quarantine differs"
merged_after=$("$ALPHORN" workers --all --json | grep -o '"name":"bad"[^}]*' | grep -o '"units_merged":"[0-9]*"' | grep -o '[0-9]*' || echo 0)
[[ $merged_before == "$merged_after" ]] || fail "the quarantined worker merged units ($merged_before -> $merged_after)"
kill -0 "$bad_pid" 2>/dev/null || fail "the quarantined worker exited"
wait_until 10 grep -q "event=worker.ineligible .*quarantined" "$WORK/worker-bad.log"
pass "the quarantined worker stays idle and logs why"

# Every job's unit.merged lines come before its job.ended line.
for job in $(grep -o "event=job.ended job=[0-9]*" "$WORK/coordinator.log" | grep -o "[0-9]*$"); do
    ended=$(grep -n "event=job.ended job=$job " "$WORK/coordinator.log" | head -n1 | cut -d: -f1)
    last=$(grep -n "event=unit.merged job=$job " "$WORK/coordinator.log" | tail -n1 | cut -d: -f1)
    [[ -n $last && $last -lt $ended ]] || fail "job $job: unit.merged at line $last after job.ended at line $ended"
done
pass "each job's merges are logged before its end"
echo "PASS"
