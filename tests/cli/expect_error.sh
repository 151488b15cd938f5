#!/usr/bin/env bash
# Runs an alphorn command that must be rejected, and checks how: exit code 1 (not a crash or
# another code), within a time limit (no hang), and a message containing every expected fragment
# (the file:line and the problem).
# Usage: expect_error.sh ALPHORN "fragment1|fragment2|..." -- ARGS...
set -u
alphorn=$1
fragments=$2
shift 3  # alphorn, fragments, "--"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# The subcommand's own arguments, then an output path inside our scratch directory for render.
args=("$@")
if [ "${args[0]}" = render ]; then
  [[ " ${args[*]} " == *" -o "* ]] || args+=(-o "$out/out.exr")
  [[ " ${args[*]} " == *" --spp "* || " ${args[*]} " == *" --passes "* ]] || args+=(--spp 1)
fi
timeout 60 "$alphorn" "${args[@]}" >"$out/stdout" 2>"$out/stderr"
status=$?
cat "$out/stdout" "$out/stderr"
if [ "$status" -eq 124 ]; then echo "FAIL: alphorn hung (killed after 60 s)"; exit 1; fi
if [ "$status" -eq 0 ]; then echo "FAIL: alphorn accepted bad input (exit code 0)"; exit 1; fi
if [ "$status" -ge 128 ]; then echo "FAIL: alphorn died of signal $((status - 128))"; exit 1; fi
if [ "$status" -ne 1 ]; then echo "FAIL: exit code $status, not the documented 1"; exit 1; fi
IFS='|' read -r -a wanted <<<"$fragments"
for fragment in "${wanted[@]}"; do
  if ! grep -qF -- "$fragment" "$out/stdout" "$out/stderr"; then
    echo "FAIL: the message does not contain \"$fragment\""
    exit 1
  fi
done
echo "OK: exit code $status with the expected message"
