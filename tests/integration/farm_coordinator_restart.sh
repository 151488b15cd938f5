#!/usr/bin/env bash
# 6c: kill -9 of the coordinator mid-job and a restart on the same state directory: the job
# resumes from its last checkpoint, completes byte-identical to `alphorn render`, and the units
# merged before the checkpoint are neither leased nor merged again (asserted from counters).
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --checkpoint-interval 0.3 --lease-seconds 2
export ALPHORN_TEST_UNIT_DELAY_MS=100  # test hook: each unit takes 100 ms longer
start_worker a
start_worker b
unset ALPHORN_TEST_UNIT_DELAY_MS

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 9 --passes 8
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 9 --passes 8 --tile 32 2>/dev/null)
checkpointed() {
    (($(job_field "$job" checkpoints_written) >= 1 && $(job_field "$job" units_done) >= 12))
}
wait_until 30 checkpointed
kill -9 "$COORDINATOR_PID"
pass "killed the coordinator (kill -9)"
sleep 0.5
start_coordinator "127.0.0.1:$PORT" --checkpoint-interval 0.3 --lease-seconds 2
grep -q "event=job.resumed job=$job" "$WORK/coordinator.log" || fail "the job was not resumed"

"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the resumed job did not finish"
"$ALPHORN" fetch "$job" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs after a coordinator restart"
pass "EXR byte-identical to alphorn render after kill -9 and restart of the coordinator"

total=$(job_field "$job" units_total)
restored=$(job_field "$job" units_restored)
merged=$(job_field "$job" units_merged_this_run)
leased=$(job_field "$job" units_leased_this_run)
# Each audit (a worker's first unit of the job in this process, and the audited share) leases its
# unit a second time, to another worker; those leases are not renders of restored units.
audited=$(job_field "$job" units_audited)
echo "units: total $total, restored from checkpoint $restored, merged after restart $merged, leased after restart $leased ($audited audited)"
((restored > 0)) || fail "nothing was restored from the checkpoint"
((restored + merged == total)) || fail "restored + merged after restart != total: a unit was merged twice or lost"
((leased - audited <= total - restored)) || fail "units restored from the checkpoint were leased (rendered) again"
pass "checkpointed units were not rendered again"
echo "units in flight re-adopted after the restart: $(grep -c "event=unit.readopted" "$WORK/coordinator.log" || true)"
echo "PASS"
