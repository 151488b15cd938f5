#!/usr/bin/env bash
# What a client says when it cannot talk to the coordinator: a plaintext client to a TLS
# coordinator and a TLS client to a plaintext one are told which option to change (at once, not
# after the wait), and an address where nothing listens fails after --reconnect-seconds with a
# clear message (at once with --reconnect-seconds 0, which still connects to a healthy
# coordinator). `watch` shows the coordinator's elapsed time, not the time since it started.
source "$(dirname "$0")/farm_lib.sh"
chmod 600 "$WORK"/*.token

openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
    -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
    -keyout "$WORK/key.pem" -out "$WORK/cert.pem" >"$WORK/openssl.log" 2>&1 || fail "openssl failed"

# Nothing listens: gives up after --reconnect-seconds, not before, and says so.
start_coordinator
plain_address=$ADDRESS
kill -TERM "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || true
started=$SECONDS
"$ALPHORN" status --reconnect-seconds 3 2>"$WORK/refused.log" && fail "status succeeded without a coordinator"
took=$((SECONDS - started))
grep -q "cannot reach the coordinator at $plain_address: no connection within [0-9]* s" "$WORK/refused.log" ||
    fail "unclear error without a coordinator: $(cat "$WORK/refused.log")"
((took >= 3 && took <= 10)) || fail "gave up after $took s instead of about 3"
pass "no coordinator: $(tail -n 1 "$WORK/refused.log")"
# --reconnect-seconds 0 gives up at the first failure, with the same message.
started=$SECONDS
"$ALPHORN" status --reconnect-seconds 0 2>"$WORK/refused0.log" && fail "status succeeded without a coordinator"
grep -q "cannot reach the coordinator at $plain_address: no connection within 0 s (nothing accepts connections there" \
    "$WORK/refused0.log" || fail "unclear error without a coordinator, --reconnect-seconds 0: $(cat "$WORK/refused0.log")"
(((SECONDS - started) <= 3)) || fail "--reconnect-seconds 0 gave up after $((SECONDS - started)) s"
pass "no coordinator, --reconnect-seconds 0: $(tail -n 1 "$WORK/refused0.log")"

# A TLS client to a plaintext coordinator.
rm -rf "$WORK/state"
start_coordinator
# --reconnect-seconds 0 means no second attempt after a failure, not no connection: a healthy
# coordinator answers every command.
"$ALPHORN" status --reconnect-seconds 0 >"$WORK/zero.txt" 2>&1 ||
    fail "status --reconnect-seconds 0 failed against a healthy coordinator: $(cat "$WORK/zero.txt")"
zero_job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --passes 1 --tile 48 --reconnect-seconds 0 2>"$WORK/zero.txt") ||
    fail "submit --reconnect-seconds 0 failed against a healthy coordinator: $(cat "$WORK/zero.txt")"
"$ALPHORN" priority "$zero_job" 2 --reconnect-seconds 0 >"$WORK/zero.txt" 2>&1 ||
    fail "priority --reconnect-seconds 0 failed against a healthy coordinator: $(cat "$WORK/zero.txt")"
"$ALPHORN" cancel "$zero_job" --reconnect-seconds 0 >"$WORK/zero.txt" 2>&1 ||
    fail "cancel --reconnect-seconds 0 failed against a healthy coordinator: $(cat "$WORK/zero.txt")"
pass "--reconnect-seconds 0 against a healthy coordinator: status, submit, priority and cancel answered"
timeout 20 "$ALPHORN" status --tls-ca "$WORK/cert.pem" 2>"$WORK/tls_to_plain.log" &&
    fail "a TLS client was served by a plaintext coordinator"
grep -q "speaks plaintext" "$WORK/tls_to_plain.log" && grep -q -- "--tls-ca" "$WORK/tls_to_plain.log" ||
    fail "no hint for a TLS client to a plaintext coordinator: $(cat "$WORK/tls_to_plain.log")"
pass "TLS client, plaintext coordinator: $(tail -n 1 "$WORK/tls_to_plain.log")"

# watch shows the coordinator's elapsed time: the job started 3 s before watch did.
export ALPHORN_TEST_UNIT_DELAY_MS=300  # test hook: a job of a few seconds
start_worker a
unset ALPHORN_TEST_UNIT_DELAY_MS
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 2 --passes 4 --tile 48 2>/dev/null)
sleep 3
"$ALPHORN" watch "$job" >/dev/null 2>"$WORK/watch.log" || fail "watch failed: $(cat "$WORK/watch.log")"
first=$(grep -m1 -o "[0-9]*:[0-9]* elapsed" "$WORK/watch.log" | cut -d' ' -f1)
[[ -n $first ]] || fail "no progress line from watch: $(cat "$WORK/watch.log")"
((10#${first%%:*} * 60 + 10#${first##*:} >= 3)) ||
    fail "watch's first line says $first elapsed for a job submitted 3 s before (its own clock, not the coordinator's)"
pass "watch shows the coordinator's elapsed time ($first at its first line)"
kill -TERM "$WORKER_PID"
wait "$WORKER_PID" || true

# A plaintext client to a TLS coordinator.
kill -TERM "$COORDINATOR_PID"
wait "$COORDINATOR_PID" || true
rm -rf "$WORK/state"
start_coordinator 127.0.0.1:0 --tls-cert "$WORK/cert.pem" --tls-key "$WORK/key.pem"
started=$SECONDS
timeout 20 "$ALPHORN" status 2>"$WORK/plain_to_tls.log" && fail "a plaintext client was served by a TLS coordinator"
grep -q "speaks TLS" "$WORK/plain_to_tls.log" && grep -q -- "--tls-ca" "$WORK/plain_to_tls.log" ||
    fail "no hint for a plaintext client to a TLS coordinator: $(cat "$WORK/plain_to_tls.log")"
(((SECONDS - started) <= 5)) || fail "the hint took $((SECONDS - started)) s (it should not wait for a reconnection)"
pass "plaintext client, TLS coordinator: $(tail -n 1 "$WORK/plain_to_tls.log")"
echo "PASS"
