#!/usr/bin/env bash
# A TLS farm survives a coordinator restart: two workers and a client waiting in `submit -o`
# (WatchJob) over TLS; the coordinator gets SIGTERM mid-job and is restarted on the same state
# directory and port. Within seconds the workers deliver the units they held and go on, the
# client says it reconnects and re-attaches, and its EXR is byte-identical to `alphorn render`.
source "$(dirname "$0")/farm_lib.sh"
chmod 600 "$WORK"/*.token

openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
    -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
    -keyout "$WORK/key.pem" -out "$WORK/cert.pem" >"$WORK/openssl.log" 2>&1 || fail "openssl failed"
tls_server=(--tls-cert "$WORK/cert.pem" --tls-key "$WORK/key.pem")
export ALPHORN_TLS_CA="$WORK/cert.pem"

start_coordinator 127.0.0.1:0 --checkpoint-interval 0.5 "${tls_server[@]}"
export ALPHORN_TEST_UNIT_DELAY_MS=250  # test hook: the job is still running across the restart
start_worker a --tls-ca "$WORK/cert.pem"
start_worker b --tls-ca "$WORK/cert.pem"
unset ALPHORN_TEST_UNIT_DELAY_MS

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 13 --passes 8
"$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 13 --passes 8 --tile 32 -o "$WORK/farm.exr" \
    >"$WORK/submit.out" 2>"$WORK/submit.log" &
submit_pid=$!
PIDS+=("$submit_pid")
job_running() { [[ $("$ALPHORN" status 1 --json 2>/dev/null | grep -o '"units_done":[0-9]*' | cut -d: -f2) -ge 6 ]]; }
wait_until 30 job_running
kill -TERM "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || fail "the coordinator did not exit cleanly on SIGTERM"
done_before=$(grep -c "event=unit.merged" "$WORK/coordinator.log" || true)
pass "stopped the TLS coordinator (SIGTERM) with $done_before of 24 units merged"
sleep 1
lines_before=$(wc -l <"$WORK/coordinator.log")
start_coordinator "127.0.0.1:$PORT" --checkpoint-interval 0.5 "${tls_server[@]}"
restarted_at=$SECONDS

# Both workers deliver to the new coordinator process within a few seconds.
worker_id() { sed -n "s/.*event=worker.registered worker=\([0-9]*\) name=$1 .*/\1/p" "$WORK/coordinator.log" | head -n1; }
merged_since_restart() {
    tail -n "+$((lines_before + 1))" "$WORK/coordinator.log" | grep -q "event=unit.merged job=1 unit=[0-9]* worker=$1 "
}
for name in a b; do
    id=$(worker_id "$name")
    [[ -n $id ]] || fail "worker $name did not register"
    wait_until 15 merged_since_restart "$id"
done
pass "both workers delivered to the restarted coordinator within $((SECONDS - restarted_at)) s"

# The waiting client re-attaches and finishes; on a broken channel it hung for minutes.
deadline=$((restarted_at + 40))
while kill -0 "$submit_pid" 2>/dev/null; do
    ((SECONDS < deadline)) || fail "submit -o still waits 40 s after the restart: $(tr '\r' '\n' <"$WORK/submit.log" | tail -n 3)"
    sleep 0.2
done
wait "$submit_pid" || fail "submit -o failed across the restart: $(tr '\r' '\n' <"$WORK/submit.log" | tail -n 3)"
grep -q "coordinator restarted, reconnecting" "$WORK/submit.log" || fail "the client did not say it reconnects"
grep -q "reconnected to the coordinator after" "$WORK/submit.log" || fail "the client did not say it reconnected"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs after a TLS coordinator restart"
pass "submit -o re-attached ($(grep -o 'reconnected to the coordinator after [0-9.]* s' "$WORK/submit.log")); EXR byte-identical to alphorn render"

"$ALPHORN" workers --json >"$WORK/workers.json" || fail "workers failed"
[[ $(grep -o '"alive":true' "$WORK/workers.json" | wc -l) == 2 ]] ||
    fail "expected two live workers after the restart: $(cat "$WORK/workers.json")"
pass "both workers are listed alive"
echo "PASS"
