#!/usr/bin/env bash
# A job that stops at a target error: two workers stop it at the same decision point as
# `alphorn render` (with any threads and tile size), with the same bytes, also across a kill -9
# and restart of the coordinator; `alphorn cluster` too; status shows the estimate and that the
# target was reached; a target without a cap is refused.
source "$(dirname "$0")/farm_lib.sh"

scene=$SCENES/farm_path.xml
target=(--seed 3 --target-error 0.1 --max-passes 64)

render_local "$scene" "$WORK/local.exr" "${target[@]}" --threads 1
render_local "$scene" "$WORK/local_tiles.exr" "${target[@]}" --threads 2 --tile 16
cmp "$WORK/local.exr" "$WORK/local_tiles.exr" || fail "threads/tile changed the stopped image"
stop=$(grep -o "wrote .* (\([0-9]*\) passes" "$WORK/local.log" | head -n1 | grep -o "([0-9]*" | tr -d '(')
[[ -n $stop && $stop -gt 4 && $stop -lt 64 ]] ||
    fail "alphorn render should stop between 4 and 64 passes, stopped at '$stop'"
grep -q "target 0.1 reached" "$WORK/local.log" || fail "alphorn render does not say the target was reached"
pass "alphorn render stops at $stop passes, the same bytes at 1 and 2 threads, tiles 64 and 16"

start_coordinator 127.0.0.1:0 --checkpoint-interval 0.3 --lease-seconds 2
export ALPHORN_TEST_UNIT_DELAY_MS=100  # test hook: each unit takes 100 ms longer
start_worker a
start_worker b
unset ALPHORN_TEST_UNIT_DELAY_MS

# A coordinator killed mid-job resumes from its checkpoint and takes the same decisions.
job=$("$ALPHORN" submit "$scene" "${target[@]}" --tile 32 2>/dev/null)
checkpointed() {
    (($(job_field "$job" checkpoints_written) >= 1 && $(job_field "$job" units_done) >= 12))
}
wait_until 30 checkpointed
kill -9 "$COORDINATOR_PID"
sleep 0.5
start_coordinator "127.0.0.1:$PORT" --checkpoint-interval 0.3 --lease-seconds 2
"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the resumed job did not finish"
"$ALPHORN" fetch "$job" -o "$WORK/restarted.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/restarted.exr" || fail "the EXR differs after a coordinator restart"
[[ $(job_field $job passes_done) == "$stop" ]] || fail "after a restart the farm stopped at $(job_field $job passes_done) passes, not $stop"
restored=$(job_field $job units_restored)
((restored > 0)) || fail "nothing was restored from the checkpoint"
pass "after kill -9 and a restart of the coordinator ($restored units restored): the same stop and bytes"

"$ALPHORN" submit "$scene" "${target[@]}" --tile 32 -o "$WORK/farm.exr" 2>"$WORK/submit.log" ||
    fail "submit failed: $(cat "$WORK/submit.log")"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the farm EXR differs from alphorn render"
job=2
[[ $(job_field $job passes_done) == "$stop" ]] || fail "the farm stopped at $(job_field $job passes_done) passes, not $stop"
[[ $(job_field $job target_reached) == true ]] || fail "status does not say the target was reached"
estimate=$(job_field $job error_estimate)
awk -v e="$estimate" 'BEGIN { exit !(e > 0 && e <= 0.1) }' || fail "error estimate '$estimate' is not within the target"
"$ALPHORN" status $job | grep -q "err .* -> 10%" || fail "status does not show the estimate: $("$ALPHORN" status $job)"
pass "two workers stop at $stop passes with the same bytes; status shows estimate $estimate"

"$ALPHORN" submit "$scene" --target-error 0.1 2>"$WORK/refused.log" && fail "a target without a cap was accepted"
grep -q "max-passes" "$WORK/refused.log" || fail "the refusal does not name --max-passes: $(cat "$WORK/refused.log")"
pass "a target without --max-passes is refused"

"$ALPHORN" cluster --workers 2 --threads 1 --render "$scene" "${target[@]}" -o "$WORK/cluster.exr" \
    >"$WORK/cluster.log" 2>&1 || fail "alphorn cluster failed"
cmp "$WORK/local.exr" "$WORK/cluster.exr" || fail "alphorn cluster's EXR differs from alphorn render"
pass "alphorn cluster --workers 2 writes the same bytes"
echo "PASS"
