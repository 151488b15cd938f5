#!/usr/bin/env bash
# An OBJ face of 5000 vertices (a circle), generated here rather than kept in the repository:
# refused with the file, line and count before tinyobjloader triangulates it (in time quadratic
# in its vertices), through expect_error.sh's checks.
# Usage: huge_face.sh ALPHORN EXPECT_ERROR
set -eu
alphorn=$1
expect_error=$2
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
awk 'BEGIN {
  n = 5000
  for (i = 0; i < n; i++) printf "v %.6f %.6f 0\n", cos(6.283185307 * i / n), sin(6.283185307 * i / n)
  printf "f"
  for (i = 1; i <= n; i++) printf " %d", i
  printf "\n"
}' >"$dir/huge_face.obj"
cat >"$dir/huge_face.xml" <<'XML'
<scene>
  <integrator type="normals"/>
  <camera type="perspective"><integer name="width" value="16"/><integer name="height" value="16"/></camera>
  <mesh type="obj"><string name="filename" value="huge_face.obj"/></mesh>
</scene>
XML
"$expect_error" "$alphorn" \
  "huge_face.xml:4:4 (mesh type=\"obj\")|OBJ file $dir/huge_face.obj:5001: a face with 5000 vertices; at most 4096" \
  -- render "$dir/huge_face.xml"
