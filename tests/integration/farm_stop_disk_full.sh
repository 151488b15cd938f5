#!/usr/bin/env bash
# A graceful SIGTERM while the state disk is full (every write under the state directory fails
# with ENOSPC, through tests/support/io_fault.cpp): the coordinator cannot write the last
# checkpoint, and says so plainly instead of exiting as if nothing were lost: exit 1, a
# checkpoint.lost line per job with the units not saved, and a sentence on stderr with the count.
# Started again on a disk with room, it renders those units again and the job ends
# byte-identical to `alphorn render`.
source "$(dirname "$0")/farm_lib.sh"
: "${IO_FAULT:?}"

mkdir -p "$WORK/state"
fault=$WORK/state-fault
LD_PRELOAD=$IO_FAULT ALPHORN_IO_FAULT_DIR="$WORK/state" ALPHORN_IO_FAULT_SWITCH=$fault \
    start_coordinator 127.0.0.1:0 --checkpoint-interval 0.3 --lease-seconds 2
export ALPHORN_TEST_UNIT_DELAY_MS=100
start_worker a
unset ALPHORN_TEST_UNIT_DELAY_MS

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 6 --passes 24
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 6 --passes 24 --tile 32 2>/dev/null)
checkpointed() { grep -q "event=checkpoint.written job=$job" "$WORK/coordinator.log"; }
wait_until 30 checkpointed
echo ENOSPC >"$fault"
failing() { grep -q "event=checkpoint.failed job=$job" "$WORK/coordinator.log"; }
wait_until 20 failing
sleep 1  # more units merge while the disk is full
kill -TERM "$COORDINATOR_PID"
status=0
wait "$COORDINATOR_PID" || status=$?
[[ $status == 1 ]] || fail "the coordinator exited $status after losing merged units, not 1"
grep -qE "event=checkpoint.lost job=$job units_unsaved=[1-9][0-9]* units_saved=[0-9]+ error=.*No space left on device" \
    "$WORK/coordinator.log" || fail "no checkpoint.lost line with the units not saved"
grep -qE "[1-9][0-9]* unit\(s\) merged since their previous checkpoints were not saved and will be rendered again" \
    "$WORK/coordinator.log" || fail "the coordinator did not say plainly what was lost"
pass "SIGTERM on a full disk: exit 1, the unsaved units counted in the log and on stderr"

rm -f "$fault"
start_coordinator "$ADDRESS" --checkpoint-interval 0.3 --lease-seconds 2
"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the job did not finish after the restart"
"$ALPHORN" fetch "$job" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs from alphorn render"
pass "restarted with room, the job rendered the lost units again; EXR byte-identical"
echo "PASS"
