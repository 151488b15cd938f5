#!/usr/bin/env bash
# `alphorn cluster` reports a worker or its coordinator that dies and starts it again (no
# <defunct> left behind), and on Ctrl-C keeps the logs in the folder it named while removing the
# state and caches.
# Usage: cluster_restart.sh ALPHORN
set -u
alphorn=$1
source "$(dirname "$0")/cluster_lib.sh"

set -m  # its own process group, and SIGINT not ignored
start_cluster --workers 2 --threads 1
set +m

# kill_and_expect_restart WHO PATTERN SUFFIX: kills the cluster's child whose command line has
# PATTERN with signal 9, expects the cluster to say "WHO (pid OLD) was killed by signal 9
# (Killed); restarted it as pid NEW" followed by SUFFIX, to run NEW and to have reaped OLD. Sets
# $victim (OLD) and $restarted (NEW).
kill_and_expect_restart() {
  local who=$1 pattern=$2 suffix=$3
  victim=$(cluster_child "$pattern")
  [ -n "$victim" ] || fail "no $who among the cluster's children"
  kill -9 "$victim"
  for _ in $(seq 100); do grep -q "$who (pid $victim) was killed by signal 9" "$out/cluster.err" && break; sleep 0.1; done
  grep -q "$who (pid $victim) was killed by signal 9 (Killed); restarted it as pid [0-9]*$suffix" "$out/cluster.err" ||
    fail "the dead $who was not reported and restarted"
  restarted=$(sed -n "s/.*$who (pid [0-9]*) .*restarted it as pid \([0-9]*\).*/\1/p" "$out/cluster.err" | tail -1)
  kill -0 "$restarted" 2>/dev/null || fail "the restarted $who (pid $restarted) is not running"
  if [ -e "/proc/$victim" ]; then fail "the killed $who $victim was not reaped (defunct)"; fi
}

# The cluster's children: the coordinator and two workers; kill one worker.
kill_and_expect_restart "worker local-1" "--name local-1" ""
tr '\0' ' ' <"/proc/$restarted/cmdline" | grep -q -- "--name local-1" || fail "pid $restarted is not worker local-1"
echo "ok   killed worker local-1 (pid $victim): reported and restarted as pid $restarted"

# A coordinator that dies is started again on the same address (before, the cluster went on
# "running" without one); the job below runs on the restarted one.
kill_and_expect_restart "cluster: coordinator" alphorn-coordinator " on 127.0.0.1:"
echo "ok   killed the coordinator (pid $victim): reported and restarted as pid $restarted"

# Farm progress counts merged units (plain lines off a terminal), and `workers` has a header.
export $(grep ALPHORN_ "$out/cluster.out" | xargs)
timeout 60 "$alphorn" submit "$(dirname "$0")/scenes/ok_normals.xml" --spp 4 --tile 16 --watch \
  >/dev/null 2>"$out/watch.err" || { cat "$out/watch.err"; fail "submit --watch failed"; }
grep -q "^job 1: [0-9]*/24 units ([0-9]*%), .* [0-9]*/4 passes" "$out/watch.err" ||
  { cat "$out/watch.err"; fail "no progress line counting units"; }
grep -q "^job 1: done, 24/24 units" "$out/watch.err" || { cat "$out/watch.err"; fail "no closing line"; }
"$alphorn" workers | head -1 | grep -q "^ID    NAME .*STATE" || fail "no header row in workers"
echo "ok   farm progress counts units; workers has a header row"

kill -INT "$cluster"
timeout 60 tail --pid="$cluster" -f /dev/null
wait "$cluster"
status=$?
cluster=""
[ "$status" -eq 0 ] || fail "exit code $status after Ctrl-C"
grep -q "cluster: logs kept in $root" "$out/cluster.err" || fail "no word about the logs kept"
for log in coordinator.log worker-0.log worker-1.log; do
  [ -s "$root/$log" ] || fail "$root/$log was not kept"
done
[ ! -e "$root/state" ] || fail "the temporary state was not removed"
[ ! -e "$root/client.token" ] || fail "the temporary tokens were not removed"
echo "ok   Ctrl-C: logs kept in $root, state and tokens removed"
