#!/usr/bin/env bash
# OBJ faces too big to triangulate (tinyobjloader's triangulation takes time quadratic in a
# face's vertices), generated here rather than kept in the repository: FACES faces of VERTICES
# vertices each, all on one circle. The scene must be refused with the file, line and figures
# by the pass before tinyobjloader, through expect_error.sh's checks of EXPECTED.
# Usage: big_faces.sh ALPHORN EXPECT_ERROR VERTICES FACES EXPECTED
# EXPECTED may name $dir (the folder of the generated files).
set -eu
source "$(dirname "$0")/big_faces_lib.sh"
alphorn=$1
expect_error=$2
vertices=$3
faces=$4
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
expected=${5//\$dir/$dir}
write_big_faces_obj "$vertices" "$faces" "$dir/big_faces.obj"
cat >"$dir/big_faces.xml" <<'XML'
<scene>
  <integrator type="normals"/>
  <camera type="perspective"><integer name="width" value="16"/><integer name="height" value="16"/></camera>
  <mesh type="obj"><string name="filename" value="big_faces.obj"/></mesh>
</scene>
XML
"$expect_error" "$alphorn" "$expected" -- render "$dir/big_faces.xml"
