#!/usr/bin/env bash
# What a client is told about the coordinator's storage names no path of the server: with the
# state directory failing (EIO and EROFS through the preloaded tests/support/io_fault.cpp), a
# control request that must write the database and a submit that must stage its scene are
# refused with messages that name state-relative files (`state.sqlite`), never the absolute
# state directory, while the coordinator's own log keeps the full path.
source "$(dirname "$0")/farm_lib.sh"
: "${IO_FAULT:?}"
chmod 600 "$WORK"/*.token

state_fault=$WORK/state-fault
LD_PRELOAD=$IO_FAULT ALPHORN_IO_FAULT_DIR="$WORK/state" ALPHORN_IO_FAULT_SWITCH=$state_fault \
    start_coordinator
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --passes 2 --tile 32 2>"$WORK/submit.log") ||
    fail "submit failed: $(cat "$WORK/submit.log")"

# expect_no_state_path FILE WHAT: FILE names no path inside the state directory.
expect_no_state_path() {
    if grep -qF "$WORK/state" "$1"; then fail "$2 names the server's state directory: $(cat "$1")"; fi
}
for error in EIO EROFS; do
    echo "$error" >"$state_fault"
    "$ALPHORN" priority "$job" 3 --reconnect-seconds 1 >"$WORK/priority.txt" 2>&1 &&
        fail "a priority change was answered while the database could not be written ($error)"
    grep -q "cannot write its state" "$WORK/priority.txt" ||
        fail "the refused priority change did not say why: $(cat "$WORK/priority.txt")"
    grep -q "state.sqlite" "$WORK/priority.txt" ||
        fail "the refused priority change does not name the database relative to the state directory: $(cat "$WORK/priority.txt")"
    expect_no_state_path "$WORK/priority.txt" "the refused priority change ($error)"
    pass "$error: priority refused with: $(tail -n1 "$WORK/priority.txt")"

    "$ALPHORN" submit "$SCENES/farm_normals.xml" --passes 1 --reconnect-seconds 1 >"$WORK/submit.txt" 2>&1 &&
        fail "a submit was accepted while the state directory could not be written ($error)"
    grep -q "state directory cannot be written" "$WORK/submit.txt" ||
        fail "the refused submit did not blame the disk: $(cat "$WORK/submit.txt")"
    expect_no_state_path "$WORK/submit.txt" "the refused submit ($error)"
    pass "$error: submit refused with: $(tail -n1 "$WORK/submit.txt")"
    rm -f "$state_fault"
done
grep -q "event=rpc.storage_error error=\"$WORK/state/state.sqlite: " "$WORK/coordinator.log" ||
    fail "the coordinator's log lost the database's full path"
pass "the coordinator's log keeps the full path"
"$ALPHORN" priority "$job" 3 >"$WORK/priority.txt" 2>&1 ||
    fail "the priority change failed with the disk back: $(cat "$WORK/priority.txt")"
pass "with the disk back, the same request is answered"
echo "PASS"
