#!/usr/bin/env bash
# Tile-adaptive passes (--adaptive): tiles of the fixed 32-pixel grid stop at different decision
# points, and the image is the same bytes at any threads and tile size, on two workers, across a
# kill -9 and restart of the coordinator, and through `alphorn cluster`.
source "$(dirname "$0")/farm_lib.sh"

scene=$SCENES/farm_path.xml
target=(--seed 3 --target-error 0.15 --max-passes 64 --adaptive)

render_local "$scene" "$WORK/local.exr" "${target[@]}" --threads 1
render_local "$scene" "$WORK/local_tiles.exr" "${target[@]}" --threads 2 --tile 16
render_local "$scene" "$WORK/local_odd_tiles.exr" "${target[@]}" --threads 2 --tile 23
cmp "$WORK/local.exr" "$WORK/local_tiles.exr" || fail "threads/tile 16 changed the adaptive image"
cmp "$WORK/local.exr" "$WORK/local_odd_tiles.exr" || fail "tile 23 changed the adaptive image"
stop=$(grep -o "wrote .* (\([0-9]*\) passes" "$WORK/local.log" | head -n1 | grep -o "([0-9]*" | tr -d '(')
[[ -n $stop && $stop -lt 64 ]] || fail "the adaptive render should stop before the cap, stopped at '$stop'"
grep -q "6 of 6 tiles met it" "$WORK/local.log" || fail "not every tile met the target: $(tail -n1 "$WORK/local.log")"
# Had every tile run to the last decision point, the image would be that of --passes $stop.
render_local "$scene" "$WORK/fixed.exr" --seed 3 --passes "$stop" --threads 2
cmp -s "$WORK/local.exr" "$WORK/fixed.exr" && fail "no tile stopped before the others"
pass "alphorn render --adaptive stops at $stop passes, tiles stopping at different points; the same bytes at threads 1/2, tiles 64/16/23"

start_coordinator 127.0.0.1:0 --checkpoint-interval 0.3 --lease-seconds 2
export ALPHORN_TEST_UNIT_DELAY_MS=100  # test hook: each unit takes 100 ms longer
start_worker a
start_worker b
unset ALPHORN_TEST_UNIT_DELAY_MS

# Killed after a decision point that finished some tiles; the resumed job keeps those decisions.
job=$("$ALPHORN" submit "$scene" "${target[@]}" --tile 16 2>/dev/null)
decided() {
    (($(job_field "$job" checkpoints_written) >= 1 && $(job_field "$job" passes_done) >= 16))
}
wait_until 60 decided
kill -9 "$COORDINATOR_PID"
sleep 0.5
start_coordinator "127.0.0.1:$PORT" --checkpoint-interval 0.3 --lease-seconds 2
"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the resumed job did not finish"
"$ALPHORN" fetch "$job" -o "$WORK/restarted.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/restarted.exr" || fail "the adaptive EXR differs after a coordinator restart"
((($(job_field $job units_restored)) > 0)) || fail "nothing was restored from the checkpoint"
pass "after kill -9 and a restart of the coordinator: the same bytes"

"$ALPHORN" submit "$scene" "${target[@]}" --tile 64 -o "$WORK/farm.exr" 2>"$WORK/submit.log" ||
    fail "submit failed: $(cat "$WORK/submit.log")"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the farm's adaptive EXR differs from alphorn render"
job=2
[[ $(job_field $job target_reached) == true ]] || fail "status does not say the target was reached"
[[ $(job_field $job adaptive_tiles_finished) == 6 && $(job_field $job adaptive_tiles) == 6 ]] ||
    fail "status does not show 6 of 6 tiles finished: $("$ALPHORN" status $job --json)"
"$ALPHORN" status $job | grep -q "6/6 tiles done" || fail "status does not show the tiles: $("$ALPHORN" status $job)"
pass "two workers (tile 64 asked, 32 used) write the same bytes; status shows 6 of 6 tiles finished"

"$ALPHORN" submit "$scene" --adaptive 2>"$WORK/refused.log" && fail "--adaptive without a target was accepted"
grep -q "target-error" "$WORK/refused.log" || fail "the refusal does not name --target-error: $(cat "$WORK/refused.log")"
pass "--adaptive without --target-error is refused"

"$ALPHORN" cluster --workers 2 --threads 1 --render "$scene" "${target[@]}" -o "$WORK/cluster.exr" \
    >"$WORK/cluster.log" 2>&1 || fail "alphorn cluster failed"
cmp "$WORK/local.exr" "$WORK/cluster.exr" || fail "alphorn cluster's adaptive EXR differs from alphorn render"
pass "alphorn cluster --workers 2 writes the same bytes"
echo "PASS"
