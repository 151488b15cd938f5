#!/usr/bin/env bash
# `alphorn cluster` whose every worker died too often to be started again stops its farm and exits
# 1 saying so: before, it went on "running" (and `--render` waited for ever on a job nobody could
# render). Here the one worker is killed until the cluster gives it up.
# Usage: cluster_no_workers.sh ALPHORN
set -u
alphorn=$1
out=$(mktemp -d)
cluster=""
trap '[ -n "$cluster" ] && kill -9 "$cluster" 2>/dev/null; [ -n "$cluster" ] && wait "$cluster" 2>/dev/null; rm -rf "$out" "${root:-/nonexistent}"' EXIT
fail() { echo "FAIL: $*"; cat "$out/cluster.err"; exit 1; }

"$alphorn" cluster --workers 1 --threads 1 >"$out/cluster.out" 2>"$out/cluster.err" &
cluster=$!
for _ in $(seq 300); do grep -q "running; Ctrl-C stops it" "$out/cluster.err" && break; sleep 0.1; done
grep -q "running; Ctrl-C stops it" "$out/cluster.err" || fail "the cluster did not start"
root=$(sed -n 's/.*; logs in \([^ ]*\) (kept on exit.*/\1/p' "$out/cluster.err")
coordinator=""
for pid in $(cat /proc/"$cluster"/task/*/children); do
  tr '\0' ' ' <"/proc/$pid/cmdline" | grep -q -- "alphorn-coordinator" && coordinator=$pid
done
[ -n "$coordinator" ] || fail "no coordinator among the cluster's children"

# Kill the worker each time the cluster starts it again, until it gives up (at most 60 s).
deadline=$((SECONDS + 60))
while kill -0 "$cluster" 2>/dev/null && grep -q "running" "$out/cluster.err" && ((SECONDS < deadline)); do
  for pid in $(cat /proc/"$cluster"/task/*/children 2>/dev/null); do
    tr '\0' ' ' <"/proc/$pid/cmdline" 2>/dev/null | grep -q -- "--name local-0" && kill -9 "$pid" 2>/dev/null
  done
  grep -q "not restarting it" "$out/cluster.err" && break
  sleep 0.05
done
grep -q "worker local-0 .* not restarting it" "$out/cluster.err" || fail "the worker was not given up"
for _ in $(seq 100); do kill -0 "$cluster" 2>/dev/null || break; sleep 0.1; done
kill -0 "$cluster" 2>/dev/null && fail "the cluster runs on with no worker left"
wait "$cluster"
status=$?
cluster=""
[ "$status" -eq 1 ] || fail "exit code $status, not 1"
grep -q "cluster: error: no worker is left" "$out/cluster.err" || fail "the cluster did not say why it stopped"
kill -0 "$coordinator" 2>/dev/null && fail "the coordinator (pid $coordinator) was left running"
[ -f "$root/coordinator.log" ] || fail "the logs were not kept"
[ -e "$root/state" ] && fail "the temporary state was not removed"
echo "OK: with no worker left the cluster stopped its farm and exited 1"
