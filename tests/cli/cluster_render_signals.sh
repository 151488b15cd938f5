#!/usr/bin/env bash
# `alphorn cluster --render` stopped by a signal stops its farm (no coordinator or worker left
# behind) and exits 128 + the signal: 130 for Ctrl-C (SIGINT), 143 for SIGTERM.
# Usage: cluster_render_signals.sh ALPHORN
set -u
alphorn=$1
scene="$(dirname "$0")/../../scenes/cbox/cbox.xml"
out=$(mktemp -d)
cluster=""
trap '[ -n "$cluster" ] && kill -9 "$cluster" 2>/dev/null; rm -rf "$out"' EXIT
fail() { echo "FAIL: $*"; cat "$out/cluster.err"; exit 1; }

for case in "INT 130" "TERM 143"; do
  read -r signal expected <<<"$case"
  set -m  # its own process group, and SIGINT not ignored
  "$alphorn" cluster --workers 1 --threads 1 --render "$scene" --spp 4096 -o "$out/image.exr" \
    >"$out/cluster.out" 2>"$out/cluster.err" &
  cluster=$!
  set +m
  for _ in $(seq 600); do grep -q "^job 1: " "$out/cluster.err" && break; sleep 0.1; done
  grep -q "^job 1: " "$out/cluster.err" || fail "the job did not start"
  root=$(sed -n 's/.*; logs in \([^ ]*\) (kept on exit.*/\1/p' "$out/cluster.err")
  [ -d "$root" ] || fail "no log folder named"
  daemons=$(cat /proc/"$cluster"/task/*/children)
  [ -n "$daemons" ] || fail "no daemons among the cluster's children"
  kill -"$signal" "$cluster"
  timeout 60 tail --pid="$cluster" -f /dev/null
  wait "$cluster"
  status=$?
  cluster=""
  [ "$status" -eq "$expected" ] || fail "exit code $status after SIG$signal, not $expected"
  for pid in $daemons; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -0 "$pid" 2>/dev/null && fail "daemon $pid was left running after SIG$signal"
  done
  rm -rf "$root"
  echo "ok   SIG$signal: exit $expected, the farm's daemons ($(echo $daemons)) stopped"
done
