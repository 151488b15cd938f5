#!/usr/bin/env bash
# 6h: a 1024x1024 job whose unit results exceed gRPC's 4 MiB message limit goes through
# (results and images are streamed in chunks) and is byte-identical to `alphorn render`.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator
start_worker a
start_worker b
render_local "$SCENES/farm_big.xml" "$WORK/local.exr" --seed 1 --passes 1
"$ALPHORN" submit "$SCENES/farm_big.xml" --seed 1 --passes 1 --tile 1024 -o "$WORK/farm.exr" 2>"$WORK/submit.log" ||
    fail "submit failed: $(cat "$WORK/submit.log")"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the 1024x1024 EXR differs"
largest=$(grep -o "event=unit.merged .*bytes=[0-9]*" "$WORK/coordinator.log" | grep -o "bytes=[0-9]*" | cut -d= -f2 | sort -n | tail -n1)
echo "largest unit result: $largest bytes (compressed); EXR: $(stat -c %s "$WORK/farm.exr") bytes"
((largest > 4 * 1024 * 1024)) || fail "the unit result was not larger than 4 MiB; the test proves nothing"
pass "unit results over 4 MiB streamed; EXR byte-identical"
echo "PASS"
