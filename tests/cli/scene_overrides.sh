#!/usr/bin/env bash
# -D name=value and --size change the scene as if it had been written so: a scene with $fov and
# $mesh rendered with -D gives the bytes of the scene with those values written in, and --size
# the bytes of the scene with that width and height.
# Usage: scene_overrides.sh ALPHORN SCENES_DIR
set -eu
alphorn=$1
scenes=$2
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
render() {  # name, scene, extra arguments
  local name=$1 scene=$2
  shift 2
  timeout 120 "$alphorn" render "$scene" -o "$out/$name.exr" --spp 2 --seed 3 "$@" 2>"$out/$name.log" ||
    { cat "$out/$name.log"; fail "render $name failed"; }
}
render written "$scenes/ok_normals.xml"
render defined "$scenes/ok_normals_parameters.xml" -D fov=45 -D mesh=sphere
cmp "$out/written.exr" "$out/defined.exr" || fail "-D fov=45 -D mesh=sphere differs from the written values"
render other "$scenes/ok_normals_parameters.xml" -D fov=30 -D mesh=sphere
if cmp -s "$out/written.exr" "$out/other.exr"; then fail "-D fov=30 did not change the image"; fi
echo "ok   -D gives the bytes of the values written in the scene"
render small "$scenes/ok_normals_20x16.xml"
render resized "$scenes/ok_normals.xml" --size 20x16
cmp "$out/small.exr" "$out/resized.exr" || fail "--size 20x16 differs from width 20, height 16 in the scene"
echo "ok   --size gives the bytes of the size written in the scene"
