#!/usr/bin/env bash
# Job and worker control on a real farm (a coordinator and two workers on loopback): pause ->
# resume -> priority -> drain -> undrain -> SIGTERM drain -> cancel and retry -> delete, the
# event log (also after a coordinator restart), refusals (a worker token, a finished job), and a
# killed worker shown silent long before it is dead. The retried job's EXR is byte for byte a
# fresh job's and `alphorn render`'s, and no lease is lost on the way (no failed attempt).
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --lease-seconds 4 --checkpoint-interval 1
export ALPHORN_TEST_UNIT_DELAY_MS=250  # each unit takes a while, so jobs are caught mid-run
start_worker a
worker_a=$WORKER_PID
start_worker b
worker_b=$WORKER_PID
unset ALPHORN_TEST_UNIT_DELAY_MS

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 3 --passes 8
submit() { "$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 3 --passes 8 --tile 32 --passes-per-unit 1 --name "$1" 2>/dev/null; }

# worker_json NAME: the worker's object in `alphorn workers --all --json`.
worker_json() { "$ALPHORN" workers --all --json | grep -o '{[^{}]*}' | grep "\"name\":\"$1\"" | head -n1; }
json_value() { grep -o "\"$1\":[^,}]*" | head -n1 | cut -d: -f2 | tr -d '"'; }
worker_id() { worker_json "$1" | json_value worker_id; }
worker_value() { worker_json "$1" | json_value "$2"; }
# event_times JOB KIND: the times of the job's events of one kind, one a line.
event_times() {
    "$ALPHORN" logs "$1" --json | grep -o '{[^{}]*}' | grep "\"kind\":\"$2\"" | json_value time_unix_seconds
}

wait_until 30 bash -c "[[ -n \$(\"$ALPHORN\" workers --json | grep -o '\"name\":\"b\"') ]]"
id_a=$(worker_id a)
id_b=$(worker_id b)
[[ -n $id_a && -n $id_b ]] || fail "the workers did not register"

# ---- authorization: control calls take the client token; the worker token is refused.
job1=$(submit first)
if ALPHORN_TOKEN_FILE="$WORK/worker.token" "$ALPHORN" pause "$job1" >"$WORK/refused.out" 2>&1; then
    fail "a worker token paused a job"
fi
grep -qi "unauthenticated\|token" "$WORK/refused.out" || fail "the refusal does not say why: $(cat "$WORK/refused.out")"
pass "a control call with the worker token is refused"

# ---- pause: no new leases; the units out finish and merge.
merged_some() { (($(job_field "$job1" units_done) >= 4)); }
wait_until 60 merged_some
"$ALPHORN" pause "$job1" >"$WORK/pause.out" 2>&1 || fail "pause failed: $(cat "$WORK/pause.out")"
grep -q "paused" "$WORK/pause.out" || fail "pause does not say the job is paused"
[[ $(job_field "$job1" paused) == true ]] || fail "status --json does not say paused"
none_leased() { [[ $(job_field "$job1" units_leased) == 0 ]]; }
wait_until 30 none_leased
done_paused=$(job_field "$job1" units_done)
sleep 2  # workers ask for work many times meanwhile
[[ $(job_field "$job1" units_done) == "$done_paused" && $(job_field "$job1" units_leased) == 0 ]] ||
    fail "a paused job was leased units"
"$ALPHORN" status | grep -E "^$job1 +paused" >/dev/null || fail "the status table does not show paused"
"$ALPHORN" status | head -n1 | grep -q "OWNER.*SUBMITTED" || fail "the status table has no owner and submit time"
owner=$(job_field "$job1" owner)
[[ $owner == "${USER:-$(id -un)}@$(hostname)" ]] || fail "the owner is \"$owner\", not the submitting user@host"
submitted=$(job_field "$job1" submitted_at_unix_seconds)
awk -v t="$submitted" -v now="$(date +%s)" 'BEGIN { exit !(t > now - 600 && t < now + 5) }' ||
    fail "the submit time $submitted is not the time of the submission"
pass "paused at $done_paused of $(job_field "$job1" units_total) units: nothing leased for 2 s"

# ---- priority: a second and a third job; the third, raised, goes before the second.
job2=$(submit second)
job3=$(submit third)
"$ALPHORN" priority "$job3" 5 >/dev/null || fail "priority failed"
[[ $(job_field "$job3" priority) == 5 ]] || fail "the new priority is not shown"
"$ALPHORN" resume "$job1" >/dev/null || fail "resume failed"
[[ $(job_field "$job1" paused) == false ]] || fail "still paused after resume"
"$ALPHORN" watch "$job3" >/dev/null 2>&1 || fail "job 3 did not finish"
raised=$(event_times "$job3" JOB_EVENT_PRIORITY_CHANGED)
last3=$(event_times "$job3" JOB_EVENT_LEASED | tail -n1)
leased2=$(event_times "$job2" JOB_EVENT_LEASED | awk -v from="$raised" -v to="$last3" '$1 > from && $1 < to' | wc -l)
[[ $leased2 == 0 ]] || fail "job 2 (priority 0) was leased $leased2 units while job 3 (priority 5) waited"
pass "priority 5: job $job3 was leased before job $job2 from the moment it was raised"

# ---- drain worker a: it finishes its unit and gets no new one; undrain: it works again.
"$ALPHORN" drain "$id_a" | grep -q "draining" || fail "drain does not show the worker draining"
a_idle() { [[ $(worker_value a leases) == 0 ]]; }
wait_until 30 a_idle
merged_a=$(worker_value a units_merged)
sleep 2
[[ $(worker_value a units_merged) == "$merged_a" && $(worker_value a leases) == 0 ]] ||
    fail "a drained worker was given units"
"$ALPHORN" workers | grep -E " a +.* draining " >/dev/null || fail "workers does not show a draining"
"$ALPHORN" undrain "$id_a" >/dev/null || fail "undrain failed"
a_works() { (($(worker_value a units_merged) > merged_a)); }
wait_until 30 a_works
pass "drained worker a took no unit for 2 s; undrained it renders again"

# ---- SIGTERM: worker b finishes and delivers its unit, says it leaves, exits 0.
b_holds() { [[ $(worker_value b leases) != 0 ]]; }
wait_until 30 b_holds
kill -TERM "$worker_b"
wait "$worker_b" || fail "worker b did not exit 0 after SIGTERM"
grep -q "event=worker.drained" "$WORK/worker-b.log" || fail "worker b did not drain"
[[ $(worker_value b state) == WORKER_STATE_LEFT ]] || fail "worker b is not shown as left: $(worker_json b)"
pass "SIGTERM: worker b delivered its unit, exited 0 and is listed as left"
ALPHORN_TEST_UNIT_DELAY_MS=250 start_worker c  # b's replacement, as an orchestrator would start

# ---- cancel and retry: the same bytes as a fresh job (job 2) and as alphorn render.
"$ALPHORN" cancel "$job1" >/dev/null || fail "cancel failed"
"$ALPHORN" retry "$job1" >"$WORK/retry.out" 2>&1 || fail "retry failed: $(cat "$WORK/retry.out")"
kept=$(job_field "$job1" units_restored)
((kept > 0)) || fail "the retry kept no unit of the checkpoint"
"$ALPHORN" watch "$job1" >/dev/null 2>&1 || fail "the retried job did not finish"
"$ALPHORN" watch "$job2" >/dev/null 2>&1 || fail "job 2 did not finish"
"$ALPHORN" fetch "$job1" -o "$WORK/retried.exr" 2>/dev/null || fail "fetch of the retried job failed"
"$ALPHORN" fetch "$job2" -o "$WORK/fresh.exr" 2>/dev/null || fail "fetch of job 2 failed"
cmp "$WORK/fresh.exr" "$WORK/retried.exr" || fail "the retried job's EXR differs from a fresh job's"
cmp "$WORK/local.exr" "$WORK/retried.exr" || fail "the retried job's EXR differs from alphorn render"
pass "retried job ($kept units kept from its checkpoint): EXR byte-identical to a fresh job and to alphorn render"
for job in "$job1" "$job2" "$job3"; do
    [[ $(job_field "$job" attempts_failed) == 0 ]] || fail "job $job has failed attempts: no lease may be lost by pause, drain or SIGTERM"
done

# ---- refusals of transitions the state does not allow.
if "$ALPHORN" pause "$job1" 2>"$WORK/refused.out"; then fail "a done job was paused"; fi
grep -q "only a running job can be paused" "$WORK/refused.out" || fail "unclear refusal: $(cat "$WORK/refused.out")"
if "$ALPHORN" retry "$job1" 2>"$WORK/refused.out"; then fail "a done job was retried"; fi
grep -q "only a failed or cancelled job" "$WORK/refused.out" || fail "unclear refusal: $(cat "$WORK/refused.out")"
pass "pausing or retrying a done job is refused with the reason"

# ---- the event log, also after a coordinator restart.
"$ALPHORN" logs "$job1" >"$WORK/logs.txt" || fail "logs failed"
for event in submitted leased merged paused resumed cancelled retried checkpointed finished; do
    grep -q " $event " "$WORK/logs.txt" || fail "the log has no $event event"
done
kill -TERM "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || true
start_coordinator "127.0.0.1:$PORT" --lease-seconds 4 --checkpoint-interval 1
"$ALPHORN" logs "$job1" >"$WORK/logs-after.txt" || fail "logs after the restart failed"
grep -q " retried " "$WORK/logs-after.txt" || fail "the log did not survive the restart"
pass "logs: every kind of event, kept across a coordinator restart"

# ---- delete: a running job only with --cancel; its files go with it.
job4=$(submit fourth)
if "$ALPHORN" delete "$job4" 2>"$WORK/refused.out"; then fail "a running job was deleted"; fi
grep -q "cancel it first" "$WORK/refused.out" || fail "unclear refusal: $(cat "$WORK/refused.out")"
"$ALPHORN" delete "$job4" --cancel | grep -q "cancelled it first" || fail "delete --cancel failed"
"$ALPHORN" delete "$job2" >/dev/null || fail "delete of a done job failed"
"$ALPHORN" delete "$job3" >/dev/null || fail "delete failed"
"$ALPHORN" delete "$job1" --json | grep -q '"blobs_removed":3' || fail "the last job's three files were not removed"
if "$ALPHORN" status "$job1" >/dev/null 2>&1; then fail "a deleted job is still listed"; fi
[[ -z $(ls "$WORK/state/jobs") ]] || fail "job directories remain: $(ls "$WORK/state/jobs")"
[[ -z $(find "$WORK/state/blobs" -type f) ]] || fail "blobs remain after deleting every job"
pass "delete: refused for a running job without --cancel; records, directories and blobs gone"

# ---- a killed worker is shown silent within seconds, not alive until it is dead.
wait_until 30 bash -c "[[ \$(\"$ALPHORN\" workers --json | grep -o '\"name\":\"a\"') ]]"
kill -9 "$worker_a"
killed_at=$SECONDS
silent() { [[ $(worker_value a state) == WORKER_STATE_SILENT ]]; }
wait_until 10 silent
pass "killed worker a shown silent after $((SECONDS - killed_at)) s (dead only after three lease periods)"
echo "PASS"
