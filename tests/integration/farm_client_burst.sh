#!/usr/bin/env bash
# A burst of 200 concurrent `alphorn status` processes against one coordinator: every one must
# succeed. (With a connection attempt cut off after 200 ms, most failed with "connection attempt
# timed out before receiving SETTINGS frame" on a busy machine.)
source "$(dirname "$0")/farm_lib.sh"
chmod 600 "$WORK"/*.token

start_coordinator
clients=200
pids=()
for i in $(seq "$clients"); do
    "$ALPHORN" status >/dev/null 2>"$WORK/status-$i.err" &
    pids+=("$!")
done
PIDS+=("${pids[@]}")
failed=0
for pid in "${pids[@]}"; do wait "$pid" || failed=$((failed + 1)); done
if ((failed > 0)); then
    cat "$WORK"/status-*.err | sed 's/ipv4:[0-9.:]*//' | sort | uniq -c | sort -rn | head -n 5
    fail "$failed of $clients concurrent status calls failed"
fi
pass "$clients concurrent status calls all succeeded in $SECONDS s"
echo "PASS"
