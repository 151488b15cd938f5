#!/usr/bin/env bash
# A worker whose cache cannot be written (here a file size limit, which stops root too, standing
# for a full or read-only disk) hands its unit back instead of failing it and stops, naming the
# cache: the job loses no attempt, and another worker renders it to the same bytes. Before, the
# broken worker took every attempt of the unit within milliseconds and failed every job.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --lease-seconds 2
render_local "$SCENES/farm_area_light.xml" "$WORK/local.exr" --seed 5 --passes 2
# The scene's sphere mesh (800 kB) does not fit under a limit of 8 KiB.
(
    ulimit -f 8
    exec "$WORKER" --coordinator "$ADDRESS" --token-file "$WORK/worker.token" \
        --cache-dir "$WORK/cache-full" --threads 1 --name full >>"$WORK/worker-full.log" 2>&1
) &
full=$!
PIDS+=("$full")
job=$("$ALPHORN" submit "$SCENES/farm_area_light.xml" --seed 5 --passes 2 --tile 32 2>/dev/null)
status=0
wait "$full" || status=$?
((status == 1)) || fail "the worker whose cache cannot be written exited with $status, not 1"
grep -q "the worker cache .*cannot be written: cannot write blob" "$WORK/worker-full.log" ||
    fail "the worker did not say that its cache cannot be written"
[[ $(job_field "$job" state) == JOB_STATE_RUNNING ]] || fail "the job ended: $(job_field "$job" state)"
[[ $(job_field "$job" attempts_failed) == 0 ]] || fail "the handed-back unit counted as a failed attempt"
pass "the worker with an unwritable cache handed its unit back and stopped"

start_worker good
"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the job did not finish on the good worker"
"$ALPHORN" fetch "$job" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs from alphorn render"
pass "another worker rendered the job; EXR byte-identical to alphorn render"

# A second worker given the cache directory of a running one would write, check and remove the
# same half-written blobs and job scenes, and units failed on both ("arrived corrupt", "cannot
# open ....partial"), each failure an attempt counted against its job. It is refused at start,
# naming the holder, and the first one goes on.
good=$WORKER_PID
"$WORKER" --coordinator "$ADDRESS" --token-file "$WORK/worker.token" --cache-dir "$WORK/cache-good" \
    --threads 1 --name twin >>"$WORK/worker-twin.log" 2>&1 &
twin=$!
PIDS+=("$twin")
for _ in $(seq 100); do kill -0 "$twin" 2>/dev/null || break; sleep 0.1; done
kill -0 "$twin" 2>/dev/null && fail "a second worker runs on the cache directory of a running one"
status=0
wait "$twin" || status=$?
((status == 1)) || fail "the second worker on one cache directory exited with $status, not 1"
grep -q "the cache directory $WORK/cache-good is in use by another worker (pid $good " \
    "$WORK/worker-twin.log" || fail "the second worker did not name the cache and its holder"
kill -0 "$good" 2>/dev/null || fail "the first worker stopped"
job2=$("$ALPHORN" submit "$SCENES/farm_area_light.xml" --seed 5 --passes 2 --tile 32 2>/dev/null)
"$ALPHORN" watch "$job2" >/dev/null 2>&1 || fail "the first worker did not render a job after the refusal"
"$ALPHORN" fetch "$job2" -o "$WORK/farm2.exr" 2>/dev/null || fail "fetch failed"
cmp -s "$WORK/farm2.exr" "$WORK/local.exr" || fail "the EXR after the refusal differs from alphorn render"
pass "a second worker on the same cache directory was refused; the first rendered the same bytes"
echo "PASS"
