#!/usr/bin/env bash
# `alphorn submit` across a coordinator restart: the coordinator creates the job and is stopped
# (SIGTERM) or killed (kill -9) before its answer reaches the client. The client waits for the
# coordinator, sends the same submission again, gets the job the first call created (its
# submission id), and renders it: exactly one job per submit, byte-identical to `alphorn render`.
source "$(dirname "$0")/farm_lib.sh"

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 4 --passes 4

# Test hook: SubmitJob holds its answer back after creating the job (until the call is cancelled).
start_hooked_coordinator() {
    ALPHORN_TEST_SUBMIT_ANSWER_DELAY_MS=60000 start_coordinator "$@"
}
job_count() { "$ALPHORN" status --json | grep -o '"job_id":' | wc -l; }

# submit_across_restart NAME SIGNAL EXPECTED_JOBS: a submit whose answer is held back, the
# coordinator stopped with SIGNAL once the job exists, and started again without the hook.
submit_across_restart() {
    local name=$1 signal=$2 expected=$3
    local hooks_before
    hooks_before=$(grep -c "event=test_hook.submit_answer_delay" "$WORK/coordinator.log" || true)
    "$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 4 --passes 4 --tile 32 -o "$WORK/$name.exr" \
        >"$WORK/$name.out" 2>"$WORK/$name.err" &
    local submit=$!
    PIDS+=("$submit")
    hooked() { (($(grep -c "event=test_hook.submit_answer_delay" "$WORK/coordinator.log" || true) > hooks_before)); }
    wait_until 60 hooked
    kill "-$signal" "$COORDINATOR_PID"
    wait "$COORDINATOR_PID" || true
    start_coordinator "127.0.0.1:$PORT"
    wait "$submit" || fail "submit across a coordinator restart ($signal) failed: $(cat "$WORK/$name.err")"
    grep -q "submitting the job: the coordinator went away .*waiting for it" "$WORK/$name.err" ||
        fail "submit did not say that it waits for the coordinator: $(cat "$WORK/$name.err")"
    grep -q "submitting the job: reconnected to the coordinator" "$WORK/$name.err" ||
        fail "submit did not say that the coordinator was back: $(cat "$WORK/$name.err")"
    (($(job_count) == expected)) || fail "$(job_count) jobs after the submit across $signal, expected $expected"
    cmp "$WORK/local.exr" "$WORK/$name.exr" || fail "the EXR of the submit across $signal differs from alphorn render"
    pass "submit across a coordinator restart ($signal): one job, byte-identical to alphorn render"
}

start_hooked_coordinator
start_worker a
submit_across_restart sigterm TERM 1

kill -TERM "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || true
start_hooked_coordinator "127.0.0.1:$PORT"
submit_across_restart sigkill KILL 2
grep -q "event=job.submitted_again" "$WORK/coordinator.log" ||
    fail "the coordinator did not log the submission sent again"
echo "PASS"
