#!/usr/bin/env bash
# Every class of error exits with its documented code (docs/operations.md, "Exit codes"): 0 for
# help and version, 1 for every usage error (CLI11's own 105-114 must not leak), bad scenes, an
# unreachable coordinator and a worker's bad command line, 3 for a cancelled farm job; and a
# misspelt subcommand or option is answered with the nearest real one.
# Usage: exit_codes.sh ALPHORN COORDINATOR WORKER SCENES_DIR
set -u
alphorn=$1 coordinator=$2 worker=$3 scenes=$4
work=$(mktemp -d)
pids=()
trap 'for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; wait "$p" 2>/dev/null; done; rm -rf "$work"' EXIT
failures=0

# expect CODE "FRAGMENT|..." -- COMMAND...: runs the command (60 s at most) and checks its exit
# code and that its output contains every fragment.
expect() {
  local want=$1 fragments=$2
  shift 3
  timeout 60 "$@" >"$work/out" 2>&1
  local got=$?
  if [ "$got" -ne "$want" ]; then
    echo "FAIL: exit code $got, not $want: $*"
    sed 's/^/    /' "$work/out" | head -5
    failures=$((failures + 1))
    return
  fi
  if [ -n "$fragments" ]; then
    IFS='|' read -r -a wanted <<<"$fragments"
    for fragment in "${wanted[@]}"; do
      if ! grep -qF -- "$fragment" "$work/out"; then
        echo "FAIL: no \"$fragment\" in the output of: $*"
        sed 's/^/    /' "$work/out" | head -5
        failures=$((failures + 1))
        return
      fi
    done
  fi
  echo "ok   $want: $*"
}

scene=$scenes/ok_normals.xml
# Help and version.
expect 0 "" -- "$alphorn" --help
expect 0 "" -- "$alphorn" render --help
expect 0 "alphorn " -- "$alphorn" --version
# Usage errors, one per CLI11 error class.
expect 1 "A subcommand is required" -- "$alphorn"
expect 1 "\"rendr\" is not an alphorn command; did you mean \"render\"?" -- "$alphorn" rendr "$scene"
expect 1 "\"workres\" is not an alphorn command; did you mean \"workers\"?" -- "$alphorn" workres
expect 1 "\"frobnicate\" is not an alphorn command" -- "$alphorn" frobnicate
expect 1 "alphorn render has no option --sed; did you mean --seed?" -- "$alphorn" render "$scene" --sed 3
expect 1 "alphorn render has no option --thread; did you mean --threads?" -- "$alphorn" render "$scene" --thread=2
expect 1 "alphorn status has no option --jsno; did you mean --json?" -- "$alphorn" status --jsno
expect 1 "alphorn render has no option --frobnicate" -- "$alphorn" render "$scene" --frobnicate
expect 1 "job is required" -- "$alphorn" watch                                   # RequiredError
expect 1 "excludes" -- "$alphorn" render "$scene" --spp 1 --passes 2            # ExcludesError
expect 1 "must be at least 1" -- "$alphorn" render "$scene" --passes 0          # ValidationError
expect 1 "threads" -- "$alphorn" render "$scene" --threads many                 # ConversionError
expect 1 "not expected" -- "$alphorn" status 1 2                                # ExtrasError
expect 1 "does not exist" -- "$alphorn" render "$work/none.xml"                 # FileError
# Bad input, and a statistical test that fails.
expect 1 "bad_nan_fov.xml:4:3" -- "$alphorn" render "$scenes/bad_nan_fov.xml" -o "$work/x.exr"
expect 1 "1 of 1 test files failed" -- "$alphorn" test "$scenes/bad_furnace_reference.xml"
# An unreachable coordinator (nothing listens on port 1).
printf '0123456789abcdef0123456789abcdef\n' >"$work/client.token"
printf 'fedcba9876543210fedcba9876543210\n' >"$work/worker.token"
chmod 600 "$work"/*.token
expect 1 "cannot reach the coordinator" -- "$alphorn" status --coordinator 127.0.0.1:1 \
  --token-file "$work/client.token" --reconnect-seconds 0
# The daemons' usage errors.
expect 1 "--coordinator is required" -- "$worker" --token-file x
expect 0 "" -- "$worker" --help

# A cancelled job: 3 from `watch`, 0 from `status` (the call itself worked).
"$coordinator" --listen 127.0.0.1:0 --state-dir "$work/state" --client-token-file "$work/client.token" \
  --worker-token-file "$work/worker.token" --port-file "$work/port" >"$work/coordinator.log" 2>&1 &
pids+=($!)
for _ in $(seq 200); do [ -s "$work/port" ] && break; sleep 0.05; done
export ALPHORN_COORDINATOR=127.0.0.1:$(cat "$work/port") ALPHORN_TOKEN_FILE=$work/client.token
# The tables: "no jobs" and "no workers" rather than nothing, then a header row.
expect 0 "no jobs" -- "$alphorn" status
expect 0 "no workers seen recently" -- "$alphorn" workers
job=$("$alphorn" submit "$scene" --spp 2 2>/dev/null)
expect 0 "JOB    STATE      NAME" -- "$alphorn" status
expect 0 "cancelled" -- "$alphorn" cancel "$job"
expect 3 "cancelled" -- "$alphorn" watch "$job"
expect 0 "cancelled" -- "$alphorn" status "$job"
expect 1 "" -- "$alphorn" watch 999

# The client config file, below the flags and the environment.
mkdir -p "$work/home/.config/alphorn"
cp "$work/client.token" "$work/home/.config/alphorn/client.token"
printf '# test farm\ncoordinator = %s\ntoken-file = client.token\n' "$ALPHORN_COORDINATOR" \
  >"$work/home/.config/alphorn/config"
expect 0 "cancelled" -- env -u ALPHORN_COORDINATOR -u ALPHORN_TOKEN_FILE -u XDG_CONFIG_HOME \
  HOME="$work/home" "$alphorn" status "$job"
expect 1 "cannot reach the coordinator at 127.0.0.1:1" -- env -u XDG_CONFIG_HOME HOME="$work/home" \
  ALPHORN_COORDINATOR=127.0.0.1:1 "$alphorn" status --reconnect-seconds 0
printf 'coordinater = 127.0.0.1:1\n' >>"$work/home/.config/alphorn/config"
expect 1 "alphorn/config:4: unknown key \"coordinater\"; did you mean \"coordinator\"?" -- \
  env -u XDG_CONFIG_HOME HOME="$work/home" "$alphorn" status

if [ "$failures" -ne 0 ]; then echo "FAIL: $failures exit code checks failed"; exit 1; fi
echo "OK: every error class exits with its documented code"
