#!/usr/bin/env bash
# A scene without an emitter is not an error: `alphorn render` exits 0, writes its image (black:
# Stability.SceneWithoutEmitterWarnsAndRendersBlack checks the pixels) and warns on stderr,
# naming the file and the line of <scene>.
# Usage: no_emitter.sh ALPHORN SCENE
set -u
alphorn=$1 scene=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
timeout 60 "$alphorn" render "$scene" --passes 2 -o "$out/out.exr" >"$out/stdout" 2>"$out/stderr"
status=$?
cat "$out/stdout" "$out/stderr"
if [ "$status" -ne 0 ]; then echo "FAIL: exit code $status, not 0"; exit 1; fi
if [ ! -s "$out/out.exr" ]; then echo "FAIL: no image written"; exit 1; fi
want="warning: $scene:3:2 (scene): the scene has no emitter"
if ! grep -qF -- "$want" "$out/stderr"; then echo "FAIL: no \"$want\" on stderr"; exit 1; fi
echo "ok"
