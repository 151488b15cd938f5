#!/usr/bin/env bash
# --crop X0,Y0,X1,Y1 renders only the tiles the crop needs and writes an image of the crop's
# size whose pixels equal, bit for bit, those of the whole image (small tiles, so that tiles are
# left out; a Gaussian filter, so that samples reach across tile edges).
# Usage: crop.sh ALPHORN COMPARE_CROP SCENE
set -eu
alphorn=$1
compare=$2
scene=$3
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
render() {  # name, extra arguments
  local name=$1
  shift
  timeout 120 "$alphorn" render "$scene" -o "$out/$name.exr" --spp 2 --seed 9 --tile 4 "$@" 2>"$out/$name.log" ||
    { cat "$out/$name.log"; echo "FAIL: render $name failed"; exit 1; }
}
render whole
for window in 13,7,29,21 0,0,5,3 30,20,40,30; do
  render crop --crop "$window"
  IFS=, read -r x0 y0 x1 y1 <<<"$window"
  "$compare" "$out/whole.exr" "$out/crop.exr" "$x0" "$y0" || { echo "FAIL: --crop $window"; exit 1; }
done
echo "OK: cropped renders equal the whole image's pixels"
