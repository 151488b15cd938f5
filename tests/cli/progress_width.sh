#!/usr/bin/env bash
# On a terminal the progress line fits its width and never wraps: every update of `alphorn render`
# run on a pseudo-terminal (script(1)) is shorter than the terminal's columns, whether the width
# comes from the terminal itself (stty cols) or, without one, from $COLUMNS; off a terminal the
# lines are plain (no carriage returns or escape codes).
# Usage: progress_width.sh ALPHORN SCENE
set -u
alphorn=$1
scene=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# check_width FILE COLUMNS: every live update ("render [##..] ..." or, without room for a bar,
# "render  N/M passes ...", after a carriage return) is shorter than COLUMNS. The closing line
# ("render: done, ...") is an ordinary log line.
check_width() {
  local file=$1 columns=$2 updates
  updates=$(tr '\r' '\n' <"$file" | sed 's/\x1b\[K//g' | grep -c '^render [^:]') || true
  [ "$updates" -ge 2 ] || { cat "$file"; fail "no progress updates seen"; }
  local longest
  longest=$(tr '\r' '\n' <"$file" | sed 's/\x1b\[K//g' | grep '^render [^:]' | awk '{ print length($0) }' | sort -n | tail -1)
  [ "$longest" -lt "$columns" ] || { cat -v "$file"; fail "a progress line has $longest characters on a $columns-column terminal"; }
  echo "ok   $updates updates, the longest $longest characters, on $columns columns"
}

run() {  # columns, how the width is given (stty or env)
  local columns=$1 how=$2 command
  command="'$alphorn' render '$scene' -o '$out/x.exr' --passes 100000 --time-limit 1.5 --threads 1"
  if [ "$how" = stty ]; then
    command="stty cols $columns rows 24; $command"
  else
    command="stty cols 0 rows 0; COLUMNS=$columns $command"
  fi
  timeout 120 script -qec "$command" /dev/null >"$out/tty.txt" 2>&1 </dev/null || { cat "$out/tty.txt"; fail "render failed"; }
  check_width "$out/tty.txt" "$columns"
}
run 50 stty
run 32 env
run 120 stty
# Off a terminal: plain lines.
timeout 120 "$alphorn" render "$scene" -o "$out/x.exr" --passes 40 --threads 1 2>"$out/plain.txt" ||
  fail "render failed"
if grep -q $'\r' "$out/plain.txt"; then fail "carriage returns off a terminal"; fi
grep -q 'render: [0-9]*/40 passes' "$out/plain.txt" || { cat "$out/plain.txt"; fail "no plain progress lines"; }
echo "OK: progress lines fit the terminal"
