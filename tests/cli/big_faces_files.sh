#!/usr/bin/env bash
# The scene's bound on triangulation work (kMaxSceneTriangulationWork, twice a file's): OBJ files
# each within the file's bound (8 faces of 4096 vertices, generated here as big_faces.sh does)
# took 0.4 s each to triangulate, so a scene naming many of them took minutes. Two such files
# load, also when a <mesh> names one of them again (a file is triangulated once); a third is
# refused, at its <mesh>, with the figures (through expect_error.sh: exit 1, no hang).
# Usage: big_faces_files.sh ALPHORN EXPECT_ERROR
set -eu
source "$(dirname "$0")/big_faces_lib.sh"
alphorn=$1
expect_error=$2
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
write_big_faces_obj 4096 8 "$dir/faces_1.obj"
cp "$dir/faces_1.obj" "$dir/faces_2.obj"
cp "$dir/faces_1.obj" "$dir/faces_3.obj"
scene() {  # name, the OBJ files of its meshes
  local name=$1
  shift
  {
    echo '<scene>'
    echo '  <integrator type="normals"/>'
    echo '  <camera type="perspective"><integer name="width" value="8"/><integer name="height" value="8"/></camera>'
    for file in "$@"; do echo "  <mesh type=\"obj\"><string name=\"filename\" value=\"$file\"/></mesh>"; done
    echo '</scene>'
  } >"$dir/$name.xml"
}
scene within faces_1.obj faces_2.obj faces_1.obj
timeout 60 "$alphorn" render "$dir/within.xml" --spp 1 -o "$dir/within.exr" >"$dir/log" 2>&1 ||
  { cat "$dir/log"; fail "two files within the scene's bound (one named twice) were refused"; }
echo "ok   two files at the scene's bound load (one named twice counts once)"
scene beyond faces_1.obj faces_2.obj faces_3.obj
"$expect_error" "$alphorn" "beyond.xml:6:4: this mesh's OBJ file faces_3.obj takes the scene beyond the triangulation work allowed|add up to 402653184 (this file 134217728), more than 268435456 (16 faces of 4096 vertices" \
  -- render "$dir/beyond.xml"
