#!/usr/bin/env bash
# `alphorn cluster` whose every worker died too often to be started again stops its farm and exits
# 1 saying so: before, it went on "running" (and `--render` waited for ever on a job nobody could
# render). Here the one worker is killed until the cluster gives it up.
# Usage: cluster_no_workers.sh ALPHORN
set -u
alphorn=$1
source "$(dirname "$0")/cluster_lib.sh"

start_cluster --workers 1 --threads 1
coordinator=$(cluster_child alphorn-coordinator)
[ -n "$coordinator" ] || fail "no coordinator among the cluster's children"

# Kill the worker each time the cluster starts it again, until it gives up (at most 60 s).
deadline=$((SECONDS + 60))
while kill -0 "$cluster" 2>/dev/null && grep -q "running" "$out/cluster.err" && ((SECONDS < deadline)); do
  worker=$(cluster_child "--name local-0")
  [ -n "$worker" ] && kill -9 "$worker" 2>/dev/null
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
