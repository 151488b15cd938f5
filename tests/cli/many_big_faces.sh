#!/usr/bin/env bash
# An OBJ file of 1000 faces of 4096 vertices each (one circle, 19 MB), generated here rather than
# kept in the repository: each face is within the vertex limit, but triangulating them all took
# about 45 s. Refused with the file, line and figures by the pass before tinyobjloader, at the
# face beyond the triangulation work allowed (the ninth), through expect_error.sh's checks.
# Usage: many_big_faces.sh ALPHORN EXPECT_ERROR
set -eu
alphorn=$1
expect_error=$2
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
awk 'BEGIN {
  n = 4096
  for (i = 0; i < n; i++) printf "v %.6f %.6f 0\n", cos(6.283185307 * i / n), sin(6.283185307 * i / n)
  for (k = 0; k < 1000; k++) {
    printf "f"
    for (i = 1; i <= n; i++) printf " %d", i
    printf "\n"
  }
}' >"$dir/many_big_faces.obj"
cat >"$dir/many_big_faces.xml" <<'XML'
<scene>
  <integrator type="normals"/>
  <camera type="perspective"><integer name="width" value="16"/><integer name="height" value="16"/></camera>
  <mesh type="obj"><string name="filename" value="many_big_faces.obj"/></mesh>
</scene>
XML
"$expect_error" "$alphorn" \
  "many_big_faces.xml:4:4 (mesh type=\"obj\")|OBJ file $dir/many_big_faces.obj:4105: a face with 4096 vertices takes the file beyond the triangulation work allowed|add up to 150994944, more than 134217728 (8 faces of 4096 vertices" \
  -- render "$dir/many_big_faces.xml"
