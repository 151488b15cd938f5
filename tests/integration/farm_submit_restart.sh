#!/usr/bin/env bash
# `alphorn submit` across a coordinator restart: the coordinator creates the job and is stopped
# (SIGTERM) or killed (kill -9) before its answer reaches the client. The client waits for the
# coordinator, sends the same submission again, gets the job the first call created (its
# submission id), and renders it: exactly one job per submit, byte-identical to `alphorn render`.
# Then the other client commands, each killed mid-call, ask again and succeed; `retry` and
# `delete` with their request id, so that each acts once.
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

# The other commands whose call may be repeated, each in flight (its answer held back by a
# test hook) when the coordinator is killed: they wait for it, ask again and succeed. Cancel is
# asked again after the first call cancelled the job. A submit whose answer outlasts the
# client's time limit (1 s) asks again with its submission id and gets the job the first call
# created.
kill -9 "$WORKER_PID"
kill -TERM "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || true
ALPHORN_TEST_ANSWER_DELAY_MS=60000 ALPHORN_TEST_ANSWER_DELAY_RPCS=ListJobs,CancelJob,GetImage,ListWorkers,GetJobLog \
    start_hooked_coordinator "127.0.0.1:$PORT"
ALPHORN_TEST_SUBMIT_TIME_LIMIT_MS=1000 "$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 4 --passes 4 \
    >"$WORK/slow.out" 2>"$WORK/slow.err" || fail "a submit past its time limit failed: $(cat "$WORK/slow.err")"
grep -q "submitting the job: no answer within the call's time limit .*same submission id" "$WORK/slow.err" ||
    fail "submit did not say that it asks again after its time limit: $(cat "$WORK/slow.err")"
slow_job=$(cat "$WORK/slow.out")
pass "submit past its time limit: asked again with its submission id and got job $slow_job"

in_flight() {
    local name=$1
    shift
    "$ALPHORN" "$@" >"$WORK/$name.out" 2>"$WORK/$name.err" &
    PIDS+=("$!")
    eval "${name}_pid=$!"
}
# The in_flight command NAME ended well, having said that it waited for the coordinator and that
# the coordinator was back.
expect_reconnected() {
    local name=$1 pid_var="${1}_pid"
    wait "${!pid_var}" || fail "alphorn $name across a coordinator restart failed: $(cat "$WORK/$name.err")"
    grep -q ": the coordinator went away .*waiting for it" "$WORK/$name.err" ||
        fail "alphorn $name did not say that it waits for the coordinator: $(cat "$WORK/$name.err")"
    grep -q ": reconnected to the coordinator" "$WORK/$name.err" ||
        fail "alphorn $name did not say that the coordinator was back: $(cat "$WORK/$name.err")"
}
in_flight status status
in_flight cancel cancel "$slow_job"
in_flight fetch fetch 1 -o "$WORK/fetched.exr"
in_flight workers workers --all
in_flight logs logs "$slow_job"
all_held() { (($(grep -c "event=test_hook.answer_delay" "$WORK/coordinator.log" || true) >= 5)); }
wait_until 60 all_held  # fetch asks for its PNG once its EXR came: after the restart
kill -9 "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || true
start_coordinator "127.0.0.1:$PORT"
for name in status cancel fetch workers logs; do
    expect_reconnected "$name"
done
grep -q "cancelled" "$WORK/cancel.out" || fail "cancel did not show the job cancelled: $(cat "$WORK/cancel.out")"
[[ $(job_field "$slow_job" state) == JOB_STATE_CANCELLED ]] || fail "job $slow_job is not cancelled"
cmp "$WORK/local.exr" "$WORK/fetched.exr" || fail "the EXR fetched across a restart differs from alphorn render"
grep -q "submitted" "$WORK/logs.out" || fail "logs printed no events: $(cat "$WORK/logs.out")"
(($(job_count) == 3)) || fail "$(job_count) jobs after the submit past its time limit, expected 3"
pass "status, cancel (asked again after it cancelled), fetch, workers and logs across a coordinator restart"

# retry and delete, each in flight when the coordinator is killed, their change stored and their
# answer held back: they wait for it and ask again with the same request id, which the
# coordinator stored with the change, so the call asked again gets the first answer rather than
# "cannot retry job N: it is running" or "no job N". Each acts once.
kill -TERM "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || true
ALPHORN_TEST_ANSWER_DELAY_MS=60000 ALPHORN_TEST_ANSWER_DELAY_RPCS=RetryJob,DeleteJob \
    start_coordinator "127.0.0.1:$PORT"
held_before=$(grep -c "event=test_hook.answer_delay" "$WORK/coordinator.log" || true)
in_flight retry retry "$slow_job"
in_flight delete delete 2
both_held() { (($(grep -c "event=test_hook.answer_delay" "$WORK/coordinator.log" || true) >= held_before + 2)); }
wait_until 60 both_held
kill -9 "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || true
start_coordinator "127.0.0.1:$PORT"
for name in retry delete; do
    expect_reconnected "$name"
    grep -q "event=job.${name}_sent_again" "$WORK/coordinator.log" ||
        fail "the coordinator did not recognise the $name asked again"
done
grep -q "job $slow_job runs again" "$WORK/retry.err" || fail "retry did not say that the job runs again: $(cat "$WORK/retry.err")"
[[ $(job_field "$slow_job" state) == JOB_STATE_RUNNING ]] || fail "job $slow_job does not run again"
(($(grep -c "retried" < <("$ALPHORN" logs "$slow_job")) == 1)) || fail "job $slow_job was not retried exactly once"
grep -q "^deleted job 2;" "$WORK/delete.out" || fail "delete did not say that it deleted job 2: $(cat "$WORK/delete.out")"
! "$ALPHORN" status 2 >/dev/null 2>&1 || fail "job 2 is still listed after its delete"
(($(job_count) == 2)) || fail "$(job_count) jobs after the delete, expected 2"
pass "retry and delete killed mid-call: asked again with their request id, answered as the first time, each acted once"
echo "PASS"
