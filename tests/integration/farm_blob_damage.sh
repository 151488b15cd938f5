#!/usr/bin/env bash
# A scene file damaged on the coordinator's disk (one byte flipped in its blob store): the
# coordinator finds it when a worker asks for it, removes it and fails the job saying so; the
# same scene submitted again is uploaded anew and renders byte-identical to `alphorn render`.
# Before, the damaged blob stayed listed as stored: every job of the scene failed with "arrived
# corrupt", and no submission uploaded it again.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --lease-seconds 2 --max-attempts 2
render_local "$SCENES/farm_area_light.xml" "$WORK/local.exr" --seed 4 --passes 2
first=$("$ALPHORN" submit "$SCENES/farm_area_light.xml" --seed 4 --passes 2 --tile 32 2>/dev/null)
# The largest blob is the sphere mesh.
blob=$(find "$WORK/state/blobs" -type f -printf '%s %p\n' | sort -n | tail -n1 | cut -d' ' -f2)
[[ -f $blob ]] || fail "no blob in the coordinator's store"
printf 'X' | dd of="$blob" bs=1 seek=1000 conv=notrunc status=none
start_worker a
"$ALPHORN" watch "$first" >/dev/null 2>&1 && fail "the job with a damaged scene file finished"
"$ALPHORN" status "$first" --json | grep -q "submit the scene again to upload it" ||
    fail "the failed job does not say that the coordinator's copy was damaged: $("$ALPHORN" status "$first" --json)"
[[ ! -e $blob ]] || fail "the damaged blob is still in the store"
grep -q "event=blob.damaged" "$WORK/coordinator.log" || fail "no blob.damaged log line"
grep -q "was damaged on its disk" "$WORK/coordinator.log" || fail "the first failure did not say why"
pass "the damaged blob was found, removed, and the job's error says to submit again"

second=$("$ALPHORN" submit "$SCENES/farm_area_light.xml" --seed 4 --passes 2 --tile 32 2>/dev/null)
"$ALPHORN" watch "$second" >/dev/null 2>&1 || fail "the job submitted again did not finish"
"$ALPHORN" fetch "$second" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs from alphorn render"
pass "submitted again, the scene was uploaded anew; EXR byte-identical to alphorn render"
echo "PASS"
