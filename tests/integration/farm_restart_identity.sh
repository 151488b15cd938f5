#!/usr/bin/env bash
# Job identity across a coordinator restart: two jobs of different scenes are running when the
# coordinator stops (SIGTERM) and restarts on the same state directory; each must finish
# byte-identical to its own `alphorn render` (a resumed job once reached the worker as "job 0",
# and the worker rendered the second job with the first job's scene). Also: a second
# coordinator on the same state directory or port is refused, and WatchJob of job 0 is a clear
# error. Removing the state directory's lock file changes none of that.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --checkpoint-interval 0.3 --lease-seconds 3
export ALPHORN_TEST_UNIT_DELAY_MS=150  # test hook: each unit takes 150 ms longer
start_worker a
unset ALPHORN_TEST_UNIT_DELAY_MS

render_local "$SCENES/farm_normals.xml" "$WORK/local1.exr" --seed 1 --passes 8
render_local "$SCENES/farm_area_light.xml" "$WORK/local2.exr" --seed 1 --passes 8
job1=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 1 --passes 8 --tile 32 2>/dev/null)
job2=$("$ALPHORN" submit "$SCENES/farm_area_light.xml" --seed 1 --passes 8 --tile 32 2>/dev/null)
job1_checkpointed() { grep -q "event=checkpoint.written job=$job1" "$WORK/coordinator.log"; }
wait_until 30 job1_checkpointed

# A second coordinator on the same state directory exits at once, naming the holder.
if "$COORDINATOR" --listen 127.0.0.1:0 --state-dir "$WORK/state" --client-token-file "$WORK/client.token" \
    --worker-token-file "$WORK/worker.token" >"$WORK/second.log" 2>&1; then
    fail "a second coordinator started on the same state directory"
fi
grep -q "in use by another coordinator (pid $COORDINATOR_PID" "$WORK/second.log" ||
    fail "the refusal does not name the holder: $(cat "$WORK/second.log")"
pass "a second coordinator on the same state directory is refused: $(cat "$WORK/second.log")"
# ... also when its lock file, which only names the holder, was removed.
rm "$WORK/state/lock"
if timeout 10 "$COORDINATOR" --listen 127.0.0.1:0 --state-dir "$WORK/state" --client-token-file "$WORK/client.token" \
    --worker-token-file "$WORK/worker.token" >"$WORK/second_unlocked.log" 2>&1; then
    fail "a second coordinator started on the same state directory once its lock file was removed"
fi
grep -q "in use by another coordinator" "$WORK/second_unlocked.log" ||
    fail "unclear refusal after the lock file was removed: $(cat "$WORK/second_unlocked.log")"
pass "... also with the lock file removed: $(cat "$WORK/second_unlocked.log")"
# ... and one on the same port (another state directory) cannot listen.
if timeout 10 "$COORDINATOR" --listen "127.0.0.1:$PORT" --state-dir "$WORK/state-other" \
    --client-token-file "$WORK/client.token" --worker-token-file "$WORK/worker.token" >"$WORK/port.log" 2>&1; then
    fail "a second coordinator listened on port $PORT"
fi
grep -q "cannot listen" "$WORK/port.log" || fail "no clear error for a taken port: $(cat "$WORK/port.log")"
pass "a second coordinator on the same port is refused"

if "$ALPHORN" watch 0 >"$WORK/watch0.log" 2>&1; then fail "watch 0 succeeded"; fi
grep -q "INTERNAL\|range_check" "$WORK/watch0.log" && fail "watch 0: $(cat "$WORK/watch0.log")"
pass "watch 0 is refused: $(tail -n1 "$WORK/watch0.log")"

kill -TERM "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || fail "the coordinator did not stop cleanly"
pass "stopped the coordinator (SIGTERM) with both jobs running"
start_coordinator "127.0.0.1:$PORT" --checkpoint-interval 0.3 --lease-seconds 3

for job in "$job1" "$job2"; do
    "$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "job $job did not finish after the restart"
    "$ALPHORN" fetch "$job" -o "$WORK/farm$job.exr" 2>/dev/null || fail "fetch $job failed"
done
cmp "$WORK/local1.exr" "$WORK/farm$job1.exr" || fail "job $job1 (normals) differs from its local render"
cmp "$WORK/local2.exr" "$WORK/farm$job2.exr" || fail "job $job2 (area light) differs from its local render"
grep -q "event=job.loaded job=0 " "$WORK/worker-a.log" && fail "the worker was told of a job 0"
pass "both jobs byte-identical to their local renders after the restart"
echo "PASS"
