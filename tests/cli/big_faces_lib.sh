# Sourced by big_faces.sh and big_faces_files.sh.
# write_big_faces_obj VERTICES FACES PATH: an OBJ file of FACES faces of VERTICES vertices each,
# all on one circle (tinyobjloader's triangulation takes time quadratic in a face's vertices).
write_big_faces_obj() {
  awk -v n="$1" -v faces="$2" 'BEGIN {
    for (i = 0; i < n; i++) printf "v %.6f %.6f 0\n", cos(6.283185307 * i / n), sin(6.283185307 * i / n)
    for (k = 0; k < faces; k++) {
      printf "f"
      for (i = 1; i <= n; i++) printf " %d", i
      printf "\n"
    }
  }' >"$3"
}
