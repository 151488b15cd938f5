#!/usr/bin/env bash
# deploy/systemd/: `systemd-analyze verify` accepts both units without a single warning (it
# exits 0 on unknown or misspelt keys, so any output fails), and every ${VAR} a unit's
# ExecStart uses is set in its example environment file. Exit 77 (skipped) without systemd.
set -euo pipefail
: "${COORDINATOR:?}" "${WORKER:?}" "${UNITS:?}"
command -v systemd-analyze >/dev/null || { echo "SKIP: systemd-analyze is not installed"; exit 77; }
WORK=$(mktemp -d /tmp/alphorn-systemd-test-XXXXXX)
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# verify checks that ExecStart's program exists: point the copies at this build's binaries.
sed "s#/usr/local/bin/alphorn-coordinator#$COORDINATOR#" "$UNITS/alphorn-coordinator.service" \
    >"$WORK/alphorn-coordinator.service"
sed "s#/usr/local/bin/alphorn-worker#$WORKER#" "$UNITS/alphorn-worker.service" >"$WORK/alphorn-worker.service"
output=$(cd "$WORK" && systemd-analyze verify alphorn-coordinator.service alphorn-worker.service 2>&1) ||
    fail "systemd-analyze verify failed: $output"
[[ -z $output ]] || fail "systemd-analyze verify warned: $output"
echo "ok   systemd-analyze verify: both units clean"

for role in coordinator worker; do
    unit=$UNITS/alphorn-$role.service
    env=$UNITS/$role.env.example
    grep -q "^EnvironmentFile=/etc/alphorn/$role.env$" "$unit" || fail "$unit does not read /etc/alphorn/$role.env"
    while read -r var; do
        grep -q "^$var=" "$env" || fail "$unit uses \$$var, which $env does not set"
    done < <(grep -v '^#' "$unit" | grep -o 'ALPHORN_[A-Z_]*' | sort -u)
done
echo "ok   every variable the units use is set in their example env files"
echo "PASS"
