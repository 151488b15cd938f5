# Shared by the tests of `alphorn cluster`: sourced after `alphorn` is set. start_cluster starts
# one in the background (pid in $cluster, its output in $out) and waits for it to run; its log
# folder is then $root. The EXIT trap kills a cluster left running and removes both folders.
out=$(mktemp -d)
cluster=""
trap '[ -n "$cluster" ] && kill -9 "$cluster" 2>/dev/null; [ -n "$cluster" ] && wait "$cluster" 2>/dev/null; rm -rf "$out" "${root:-/nonexistent}"' EXIT
fail() { echo "FAIL: $*"; cat "$out/cluster.err"; exit 1; }

# start_cluster ARGS...: `alphorn cluster ARGS...`, as its own process group when job control is
# on (set -m), so that SIGINT reaches it as a Ctrl-C would.
start_cluster() {
  "$alphorn" cluster "$@" >"$out/cluster.out" 2>"$out/cluster.err" &
  cluster=$!
  for _ in $(seq 300); do grep -q "running; Ctrl-C stops it" "$out/cluster.err" && break; sleep 0.1; done
  grep -q "running; Ctrl-C stops it" "$out/cluster.err" || fail "the cluster did not start"
  root=$(sed -n 's/.*; logs in \([^ ]*\) (kept on exit.*/\1/p' "$out/cluster.err")
  [ -d "$root" ] || fail "no log folder named"
}

# cluster_child PATTERN: the pid of the cluster's child process whose command line has PATTERN
# (empty when none has).
cluster_child() {
  local pid
  for pid in $(cat /proc/"$cluster"/task/*/children 2>/dev/null); do
    if tr '\0' ' ' <"/proc/$pid/cmdline" 2>/dev/null | grep -q -- "$1"; then
      echo "$pid"
      return
    fi
  done
}
