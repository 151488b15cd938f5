#!/usr/bin/env bash
# `alphorn render` and an output it cannot write: refused before rendering when the path cannot
# be written at all; when the write fails at the end (the folder removed during the render, a
# full disk) the earlier image at the path is kept whole, no partial file is left, and the new
# image goes to the temporary folder, named in the error (exit 1).
# Usage: unwritable_output.sh ALPHORN SCENE
set -u
alphorn=$1
scene=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
mkdir -p "$work/tmp"
export TMPDIR=$work/tmp

# A directory where the image should go: refused before the first pass.
mkdir -p "$work/dir.exr"
"$alphorn" render "$scene" -o "$work/dir.exr" --passes 2 >"$work/dir.log" 2>&1 && fail "a directory as the output was accepted"
grep -qF "cannot write the image to $work/dir.exr: it is a directory" "$work/dir.log" || fail "no reason given: $(cat "$work/dir.log")"
grep -q "passes" "$work/dir.log" && fail "rendered before refusing the output: $(cat "$work/dir.log")"

# The output's folder removed during the render: the image is saved in the temporary folder.
mkdir -p "$work/gone"
"$alphorn" render "$scene" -o "$work/gone/a.exr" --passes 400 --size 64x48 --seed 3 >"$work/gone.log" 2>&1 &
pid=$!
for _ in $(seq 600); do
  grep -q '/400 passes' "$work/gone.log" && break
  sleep 0.05
done
rm -rf "$work/gone"
wait "$pid" && fail "a render whose folder went away exited 0"
saved=$(sed -n 's/.*the image was saved to \([^ ]*\.exr\) and .*/\1/p' "$work/gone.log")
[ -n "$saved" ] || fail "no fallback named: $(tail -2 "$work/gone.log")"
case "$saved" in "$work/tmp/"*) ;; *) fail "the fallback $saved is not in TMPDIR" ;; esac
"$alphorn" render "$scene" -o "$work/direct.exr" --passes 400 --size 64x48 --seed 3 >/dev/null 2>&1 || fail "the direct render failed"
cmp -s "$saved" "$work/direct.exr" || fail "the saved image differs from the same render written directly"
[ -s "${saved%.exr}.png" ] || fail "no PNG beside the saved EXR"

# A full disk (a file size limit fails writes the same way, also for root): the earlier image
# stays byte for byte, nothing partial is left, and the error says the fallback failed too (the
# limit applies there as well).
mkdir -p "$work/full"
cp "$work/direct.exr" "$work/full/a.exr"
(
  ulimit -f 16
  trap '' XFSZ
  exec "$alphorn" render "$scene" -o "$work/full/a.exr" --passes 2 --size 64x48 --seed 9
) >"$work/full.log" 2>&1 && fail "a write past the file size limit exited 0"
grep -q "cannot write EXR" "$work/full.log" || fail "no write error reported: $(tail -2 "$work/full.log")"
grep -q "instead failed too" "$work/full.log" || fail "the fallback's failure is not reported: $(tail -2 "$work/full.log")"
cmp -s "$work/direct.exr" "$work/full/a.exr" || fail "the earlier image was damaged"
[ "$(ls -A "$work/full")" = "a.exr" ] || fail "partial files left: $(ls -A "$work/full")"
[ -z "$(ls -A "$work/tmp" | grep -v '^alphorn-.*-a\.\(exr\|png\)$')" ] || fail "partial files in TMPDIR: $(ls -A "$work/tmp")"
echo "ok"
