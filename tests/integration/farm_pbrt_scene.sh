#!/usr/bin/env bash
# A pbrt-v4 scene through the farm: the client bundles the .pbrt file and everything it names
# (an included file, a PLY mesh), two workers render it, and the EXR is byte-identical to
# `alphorn render`; a second submit uploads nothing; an include by absolute path is refused naming
# the directive.
source "$(dirname "$0")/farm_lib.sh"

# A copy of the example scene, with its files, at a size the test renders in seconds.
cp -r "$SCENES/../../../scenes/pbrt" "$WORK/pbrt"
SCENE=$WORK/pbrt/showcase.pbrt
sed -i 's/"integer xresolution" 480 "integer yresolution" 320/"integer xresolution" 96 "integer yresolution" 64/' "$SCENE"
grep -q '"integer xresolution" 96' "$SCENE" || fail "the example scene's film line has changed; adapt this test"

start_coordinator
start_worker a
start_worker b

render_local "$SCENE" "$WORK/local.exr" --seed 4 --passes 4
"$ALPHORN" submit "$SCENE" --seed 4 --passes 4 --tile 16 -o "$WORK/farm.exr" \
    2>"$WORK/submit1.log" || fail "submit failed: $(cat "$WORK/submit1.log")"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the farm EXR of the pbrt scene differs from alphorn render"
pass "a pbrt-v4 scene renders on the farm with the bytes of alphorn render"
grep -q "uploaded 3 blobs" "$WORK/submit1.log" ||
    fail "the scene, its included file and its PLY mesh should be uploaded: $(cat "$WORK/submit1.log")"
"$ALPHORN" submit "$SCENE" --seed 4 --passes 4 -o "$WORK/farm2.exr" \
    2>"$WORK/submit2.log" || fail "the second submit failed: $(cat "$WORK/submit2.log")"
grep -q "uploaded" "$WORK/submit2.log" && fail "the second submit should reuse every blob: $(cat "$WORK/submit2.log")"
cmp "$WORK/local.exr" "$WORK/farm2.exr" || fail "the second job's EXR differs"
pass "the second job reuses every blob"

# An include outside the scene's directory travels in the bundle too; an absolute one, which the
# farm could not bundle, is refused by the client naming the directive.
mkdir -p "$WORK/parent/inner"
printf 'Camera "perspective"\nFilm "rgb" "integer xresolution" 8 "integer yresolution" 8\nWorldBegin\nLightSource "infinite"\nInclude "../outside.pbrt"\n' \
    >"$WORK/parent/inner/scene.pbrt"
printf 'Shape "sphere"\n' >"$WORK/parent/outside.pbrt"
render_local "$WORK/parent/inner/scene.pbrt" "$WORK/parent_local.exr" --seed 2 --passes 2
"$ALPHORN" submit "$WORK/parent/inner/scene.pbrt" --seed 2 --passes 2 -o "$WORK/parent_farm.exr" \
    2>"$WORK/parent.log" || fail "a scene including a file beside its directory failed: $(cat "$WORK/parent.log")"
cmp "$WORK/parent_local.exr" "$WORK/parent_farm.exr" || fail "the EXR of the scene with ../ include differs"
printf 'WorldBegin\nInclude "%s"\n' "$WORK/parent/outside.pbrt" >"$WORK/parent/inner/absolute.pbrt"
if "$ALPHORN" submit "$WORK/parent/inner/absolute.pbrt" --passes 1 2>"$WORK/absolute.log"; then
    fail "a scene including a file by its absolute path was accepted"
fi
grep -q 'absolute.pbrt:2:1' "$WORK/absolute.log" || fail "the refusal does not name the Include: $(cat "$WORK/absolute.log")"
pass "an include beside the scene's directory is bundled; an absolute one is refused at its line"
echo "PASS"
