#!/usr/bin/env bash
# 6e (first half) and 6f: every RPC refuses a missing or wrong token, and each role's token
# works only for its own service; hostile bundle paths, oversized blobs and hash mismatches
# are refused; a malformed scene fails at submit with file and line.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --max-blob-bytes 50000
"$PROBE" auth-matrix "$ADDRESS" "$WORK/client.token" "$WORK/worker.token" >"$WORK/auth.log" 2>&1 ||
    fail "token checks: $(grep FAIL "$WORK/auth.log")"
pass "$(grep -c '^ok' "$WORK/auth.log") token checks over all 13 RPCs and 4 callers"
"$PROBE" hostile-input "$ADDRESS" "$WORK/client.token" >"$WORK/hostile.log" 2>&1 ||
    fail "hostile input: $(cat "$WORK/hostile.log")"
cat "$WORK/hostile.log"

# The CLI with a wrong token, and a worker holding the client token, are refused.
openssl rand -hex 32 >"$WORK/wrong.token"
"$ALPHORN" status --token-file "$WORK/wrong.token" 2>"$WORK/wrong.log" && fail "status with a wrong token succeeded"
grep -q "wrong token" "$WORK/wrong.log" || fail "unexpected message: $(cat "$WORK/wrong.log")"
"$WORKER" --coordinator "$ADDRESS" --token-file "$WORK/client.token" --cache-dir "$WORK/cache-x" \
    >"$WORK/worker-x.log" 2>&1 && fail "a worker with the client token was accepted"
grep -q "refused registration" "$WORK/worker-x.log" || fail "unexpected: $(cat "$WORK/worker-x.log")"
pass "CLI with a wrong token and worker with the client token are refused"

# A malformed scene through the CLI: the loader's file:line message, non-zero exit, no job.
mkdir -p "$WORK/scene"
printf '<scene>\n  <integrator type="normals"/>\n  <camera type="perspective">\n    <integer name="width" value="-5"/>\n  </camera>\n</scene>\n' >"$WORK/scene/bad.xml"
"$ALPHORN" submit "$WORK/scene/bad.xml" 2>"$WORK/bad.log" && fail "a malformed scene was accepted"
grep -q "bad.xml:[0-9]*:[0-9]*" "$WORK/bad.log" || fail "no file:line in: $(cat "$WORK/bad.log")"
pass "malformed scene refused with file:line: $(head -n1 "$WORK/bad.log")"
echo "PASS"
