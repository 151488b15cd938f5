#!/usr/bin/env bash
# 6e (second half): a unit that crashes its worker every time (test hook
# ALPHORN_TEST_CRASH_UNIT=NAME:UNIT makes the worker abort on that unit) fails its job after
# --max-attempts, while another job on the same farm completes byte-identical. The workers run
# under a restart loop, as systemd or Kubernetes would restart them.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --lease-seconds 1 --max-attempts 2
LOOPS=()
supervised_worker() {
    local name=$1
    (
        child=""
        trap '[[ -n $child ]] && kill -9 $child 2>/dev/null; exit 0' TERM
        while :; do
            ALPHORN_TEST_CRASH_UNIT=poison:2 "$WORKER" --coordinator "$ADDRESS" --token-file "$WORK/worker.token" \
                --cache-dir "$WORK/cache-$name" --threads 1 --name "$name" >>"$WORK/worker-$name.log" 2>&1 &
            child=$!
            wait "$child" || true
            sleep 0.2
        done
    ) &
    LOOPS+=($!)
}
stop_loops() { for pid in "${LOOPS[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done; }
trap 'stop_loops; cleanup' EXIT
supervised_worker a
supervised_worker b

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 2 --passes 4
poison=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --name poison --passes 2 --tile 32 --priority 1 2>/dev/null)
"$ALPHORN" submit "$SCENES/farm_normals.xml" --name healthy --seed 2 --passes 4 --tile 32 -o "$WORK/farm.exr" \
    2>"$WORK/healthy.log" || fail "the healthy job failed: $(cat "$WORK/healthy.log")"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the healthy job's EXR differs"
pass "the healthy job completed byte-identical next to a poison unit"

failed() { [[ $(job_field "$poison" state) == JOB_STATE_FAILED ]]; }
wait_until 30 failed
error=$("$ALPHORN" status "$poison" --json | grep -o '"error":"[^"]*')
echo "poison job: $error"
[[ $error == *"unit 2 failed 2 times"* ]] || fail "unexpected error: $error"
"$ALPHORN" watch "$poison" >/dev/null 2>&1 && fail "watch of a failed job must not exit 0"
(($(grep -c "event=test_hook.crash" "$WORK"/worker-*.log | awk -F: '{s+=$2} END {print s}') >= 2)) ||
    fail "the workers should have crashed at least twice"
pass "the poison unit failed its job after 2 attempts; the farm kept working"
echo "PASS"
