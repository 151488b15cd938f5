#!/usr/bin/env bash
# The coordinator's state directory, and a worker's cache, failing mid-job: every write, fsync,
# rename and create under them fails with EIO (a dying disk) or EROFS (a file system the kernel
# made read-only after an error) for a while, through the preloaded library of
# tests/support/io_fault.cpp (the daemons are the real binaries). Three jobs run meanwhile.
# Nothing may crash or hang. A worker whose cache fails hands its unit back and stops, saying
# why. A submit during the fault is refused, blaming the coordinator's disk (not the scene);
# status keeps answering; a control request waits and is answered once the disk is back;
# SIGTERM during the fault stops the coordinator; a coordinator started on the failing directory
# is refused, naming the file and the error; kill -9 during the fault and a restart after it lose
# nothing. Every job's EXR is byte-identical to its `alphorn render`, and can be fetched while the
# disk is read-only.
source "$(dirname "$0")/farm_lib.sh"
: "${IO_FAULT:?}"

mkdir -p "$WORK/state"
state_fault=$WORK/state-fault
cache_fault=$WORK/cache-fault
coordinator_flags=(--checkpoint-interval 0.3 --lease-seconds 2)
start_faulty_coordinator() {
    LD_PRELOAD=$IO_FAULT ALPHORN_IO_FAULT_DIR="$WORK/state" ALPHORN_IO_FAULT_SWITCH=$state_fault \
        start_coordinator "${1:-127.0.0.1:0}" "${coordinator_flags[@]}"
}
start_faulty_coordinator

export ALPHORN_TEST_UNIT_DELAY_MS=250  # test hook: units long enough for faults to land mid-job
start_worker a
worker_a=$WORKER_PID
LD_PRELOAD=$IO_FAULT ALPHORN_IO_FAULT_DIR="$WORK/cache-b" ALPHORN_IO_FAULT_SWITCH=$cache_fault \
    start_worker b
worker_b=$WORKER_PID
unset ALPHORN_TEST_UNIT_DELAY_MS

scenes=(farm_normals farm_photon farm_fog)
for i in 0 1 2; do render_local "$SCENES/${scenes[$i]}.xml" "$WORK/local$i.exr" --seed 9 --passes 40; done
jobs=()
for i in 0 1 2; do
    jobs+=("$("$ALPHORN" submit "$SCENES/${scenes[$i]}.xml" --seed 9 --passes 40 --tile 32 2>>"$WORK/submit.log")")
done

# A worker whose cache cannot be written hands its unit back and stops, saying so (a unit that
# fails for the worker's disk must not count against the job).
echo EIO >"$cache_fault"
for _ in $(seq 200); do kill -0 "$worker_b" 2>/dev/null || break; sleep 0.1; done
kill -0 "$worker_b" 2>/dev/null && fail "worker b went on with a cache it cannot write"
wait "$worker_b" && fail "worker b exited 0 on a cache it cannot write"
grep -q "cache-b cannot be written: .*Input/output error" "$WORK/worker-b.log" ||
    fail "worker b did not say why it stopped: $(tail -n2 "$WORK/worker-b.log")"
handed=$(grep -o "event=cache.unusable job=[0-9]* unit=[0-9]*" "$WORK/worker-b.log" | head -n1 | cut -d' ' -f2-)
[[ -n $handed ]] || fail "worker b did not name the unit it could not take"
grep -q "event=unit.handed_back $handed " "$WORK/coordinator.log" || fail "worker b kept its unit ($handed)"
pass "worker b's cache failing: it handed its unit back and stopped, naming the cache and error"
rm -f "$cache_fault"
ALPHORN_TEST_UNIT_DELAY_MS=250 start_worker b
worker_b=$WORKER_PID
units_done_at_least() { (($(job_field "$1" units_done) >= $2)); }
wait_until 30 units_done_at_least "${jobs[0]}" 4

# fault_on ERROR / fault_off: the state directory's disk fails with ERROR, or works again.
fault_on() { echo "$1" >"$state_fault"; }
fault_off() { rm -f "$state_fault"; }
# expect_output FILE TEXT WHAT: FILE holds TEXT.
expect_output() { grep -q "$2" "$1" || fail "$3: $(cat "$1")"; }

fault_on EIO
if "$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 1 --passes 2 >"$WORK/out.txt" 2>&1; then
    fail "a submit succeeded while the state directory could not be written"
fi
expect_output "$WORK/out.txt" "state directory cannot be written (Input/output error)" \
    "the refused submit did not blame the coordinator's disk"
status_says_checkpoints_fail() {
    "$ALPHORN" status >"$WORK/out.txt" 2>&1 || fail "status failed while only writes fail: $(cat "$WORK/out.txt")"
    grep -q "cannot write the checkpoint (.*Input/output error); retrying" "$WORK/out.txt"
}
wait_until 10 status_says_checkpoints_fail
pass "EIO: submit refused, blaming the disk; status answers and says the checkpoints fail"

# A control request waits for the disk, and is answered once it is back.
"$ALPHORN" priority "${jobs[2]}" 3 --reconnect-seconds 30 >"$WORK/priority.txt" 2>&1 &
priority_pid=$!
PIDS+=("$priority_pid")
sleep 1.5
kill -0 "$priority_pid" 2>/dev/null || fail "the priority request ended while the disk failed: $(cat "$WORK/priority.txt")"
fault_off
wait "$priority_pid" || true
expect_output "$WORK/priority.txt" "cannot write its state" "the waiting request did not say why it waited"
pass "a priority change during the fault waited for the disk and was answered after it"
# The next checkpoint written says how many attempts failed before it (retried every 0.3 s).
recovered() { grep -qE "event=checkpoint.recovered job=[0-9]+ failed_attempts=([2-9]|[1-9][0-9])" "$WORK/coordinator.log"; }
wait_until 10 recovered
pass "the checkpoints recovered, logged with the count of failed attempts"

fault_on EROFS
sleep 1
t0=$SECONDS
kill -TERM "$COORDINATOR_PID"
for _ in $(seq 200); do kill -0 "$COORDINATOR_PID" 2>/dev/null || break; sleep 0.1; done
kill -0 "$COORDINATOR_PID" 2>/dev/null && fail "the coordinator did not stop within 20 s of SIGTERM on a read-only disk"
wait "$COORDINATOR_PID" 2>/dev/null || true
pass "EROFS: SIGTERM stopped the coordinator in $((SECONDS - t0)) s"

for error in EROFS EIO; do
    fault_on $error
    if LD_PRELOAD=$IO_FAULT ALPHORN_IO_FAULT_DIR="$WORK/state" ALPHORN_IO_FAULT_SWITCH=$state_fault \
        timeout 20 "$COORDINATOR" --listen 127.0.0.1:0 --state-dir "$WORK/state" \
        --client-token-file "$WORK/client.token" --worker-token-file "$WORK/worker.token" \
        >"$WORK/out.txt" 2>&1; then
        fail "a coordinator started on a state directory that cannot be written ($error)"
    fi
    [[ $error == EROFS ]] && text="Read-only file system" || text="Input/output error"
    expect_output "$WORK/out.txt" "state/lock.*$text" "the refused start did not name the file and error"
done
pass "a coordinator started on the failing directory is refused, naming the file and the error"

fault_off
start_faulty_coordinator "127.0.0.1:$PORT"
sleep 1.5
fault_on EIO
sleep 1
kill -9 "$COORDINATOR_PID"
wait "$COORDINATOR_PID" 2>/dev/null || true
fault_off
log_lines=$(wc -l <"$WORK/coordinator.log")
start_faulty_coordinator "127.0.0.1:$PORT"
tail -n +"$((log_lines + 1))" "$WORK/coordinator.log" | grep -q "event=job.resumed" ||
    fail "no job was left to resume after the kill -9: the faults did not land mid-job"
pass "kill -9 during EIO, restarted after it: the jobs resumed"

for i in 0 1 2; do
    timeout 120 "$ALPHORN" watch "${jobs[$i]}" >/dev/null 2>"$WORK/watch.log" ||
        fail "job ${jobs[$i]} did not finish: $(tail -n2 "$WORK/watch.log")"
    "$ALPHORN" fetch "${jobs[$i]}" -o "$WORK/farm$i.exr" 2>>"$WORK/fetch.log" || fail "fetch ${jobs[$i]} failed"
    cmp "$WORK/local$i.exr" "$WORK/farm$i.exr" || fail "job ${jobs[$i]} (${scenes[$i]}) differs from its local render"
done
pass "all three jobs byte-identical to their local renders"
# A finished job's image can be fetched while the disk is read-only: the images are encoded in
# memory, not through a scratch file in the state directory.
fault_on EROFS
"$ALPHORN" fetch "${jobs[0]}" -o "$WORK/again.exr" --reconnect-seconds 2 >"$WORK/out.txt" 2>&1 ||
    fail "fetch failed while the state directory was read-only: $(cat "$WORK/out.txt")"
cmp "$WORK/local0.exr" "$WORK/again.exr" || fail "the EXR fetched during the fault differs"
cmp "$WORK/local0.png" "$WORK/again.png" || fail "the PNG fetched during the fault differs"
fault_off
pass "EROFS: a finished job's EXR and PNG fetched, byte-identical"
[[ $(job_field "${jobs[2]}" priority) == 3 ]] || fail "the priority asked for during the fault is not the job's"
grep -q "event=checkpoint.failed.*Input/output error" "$WORK/coordinator.log" ||
    fail "the coordinator did not log its failed checkpoints"
# Checkpoints are retried every 0.3 s here, dozens of times over the episodes; the log says a
# job's failure once per error (then once a minute) and its recovery with the count: at most
# 3 jobs x 3 episodes (EIO, EROFS, EIO after the restart) lines. Logging every retry gave 14.
failed_lines=$(grep -c "event=checkpoint.failed" "$WORK/coordinator.log")
((failed_lines <= 9)) || fail "checkpoint.failed logged $failed_lines times: once per job and error is enough"
pass "failed checkpoints logged $failed_lines times in all"
kill -0 "$worker_a" 2>/dev/null || fail "worker a died: $(tail -n3 "$WORK/worker-a.log")"
kill -0 "$worker_b" 2>/dev/null || fail "worker b died: $(tail -n3 "$WORK/worker-b.log")"
pass "both workers alive"
echo "PASS"
