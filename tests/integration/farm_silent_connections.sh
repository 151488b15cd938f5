#!/usr/bin/env bash
# Connections that never speak: a client holding more of them than the coordinator's soft file
# limit must not lock everyone out (at the limit gRPC's listener stops accepting for good), and
# the coordinator closes them after its handshake timeout (10 s).
source "$(dirname "$0")/farm_lib.sh"
chmod 600 "$WORK"/*.token

hard=$(ulimit -Hn)
[[ $hard == unlimited ]] && hard=1048576
((hard >= 2048)) || fail "the hard file limit ($hard) is too low for this test"
ulimit -Sn 256  # the coordinator starts with a soft limit of 256 ...
start_coordinator
ulimit -Sn 2048  # ... and this shell opens more connections than that
grep -q "event=limits.open_files before=256" "$WORK/coordinator.log" ||
    fail "the coordinator did not raise its open file limit"
baseline=$(ls "/proc/$COORDINATOR_PID/fd" | wc -l)

silent=600
for _ in $(seq "$silent"); do
    exec {fd}<>"/dev/tcp/127.0.0.1/$PORT" || fail "connection refused"
done
"$ALPHORN" status >/dev/null || fail "status failed with $silent silent connections open"
pass "status answered beside $silent silent connections (soft limit at start: 256)"

deadline=$((SECONDS + 30))
until (($(ls "/proc/$COORDINATOR_PID/fd" | wc -l) < baseline + 20)); do
    ((SECONDS < deadline)) || fail "the silent connections were still open after 30 s"
    sleep 0.5
done
pass "the coordinator closed the silent connections after its handshake timeout"
"$ALPHORN" status >/dev/null || fail "status failed after the silent connections were closed"
echo "PASS"
