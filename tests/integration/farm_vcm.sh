#!/usr/bin/env bash
# vcm and bdpt on two workers, split into units of (pass range x tile): the light-tracing splats
# land anywhere on the image, and each unit adds those on its own tile from the pass data it
# built itself. The EXR must be byte-identical to `alphorn render`, and each pass's light paths
# traced about once (farm locality, as for photon maps).
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0
start_worker a
start_worker b

render_local "$SCENES/farm_vcm.xml" "$WORK/local.exr" --seed 5 --passes 8
"$ALPHORN" submit "$SCENES/farm_vcm.xml" --seed 5 --passes 8 --tile 32 --passes-per-unit 2 \
    -o "$WORK/farm.exr" 2>"$WORK/submit1.log" || fail "submit failed: $(cat "$WORK/submit1.log")"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the farm EXR differs from alphorn render"
pass "vcm: farm EXR byte-identical to alphorn render (32-pixel tiles, 2 passes per unit)"
builds=$(job_field 1 pass_data_builds)
[[ -n $builds ]] && ((builds >= 8 && builds <= 12)) ||
    fail "light passes traced $builds times for 8 passes (expected 8..12: duplication <= 1.5)"
pass "light passes traced $builds times for 8 passes on 2 workers"
"$ALPHORN" status 1 | grep -q "photon radius" || fail "'alphorn status' does not show the merge radius"
pass "status shows vcm's merge radius"

render_local "$SCENES/farm_bdpt.xml" "$WORK/local_bdpt.exr" --seed 5 --passes 4 --tile 7
"$ALPHORN" submit "$SCENES/farm_bdpt.xml" --seed 5 --passes 4 --tile 16 \
    -o "$WORK/farm_bdpt.exr" 2>"$WORK/submit2.log" || fail "submit failed: $(cat "$WORK/submit2.log")"
cmp "$WORK/local_bdpt.exr" "$WORK/farm_bdpt.exr" || fail "the bdpt farm EXR differs from alphorn render"
pass "bdpt: farm EXR (16-pixel tiles) byte-identical to alphorn render (7-pixel tiles)"
echo "PASS"
