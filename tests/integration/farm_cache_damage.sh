#!/usr/bin/env bash
# A scene file damaged in a worker's cache (4 bytes of the cached quad mesh overwritten, turning
# a vertex's "v -1" into "v -3"): first while the worker is down, with the blob's size and
# modification time left as they were, then while it runs, between two jobs, with its
# modification time changed. Each time the worker finds the damage before it lays out the next
# job's scene, logs blob.corrupt, counts it in alphorn_worker_blobs_corrupt_total, fetches the
# blob again from the coordinator, and the job's EXR is byte-identical to `alphorn render`.
# Before, the damaged blob was reused unchecked: the jobs ended done with a wrong image.
source "$(dirname "$0")/farm_lib.sh"

SCENE_XML=$SCENES/farm_area_light.xml
MESH=$SCENES/../../../scenes/meshes/quad.obj
SHA=$(sha256sum "$MESH" | cut -d' ' -f1)
BLOB=$WORK/cache-a/blobs/$SHA
# Offset 36 is the start of the mesh's first vertex line, "v -1.000000 0.000000 -1.000000".
[[ $(dd if="$MESH" bs=1 skip=36 count=4 status=none) == "v -1" ]] ||
    fail "quad.obj no longer has its first vertex line at offset 36"

# start_cache_worker: worker a on $WORK/cache-a, serving /metrics; sets HTTP_A.
start_cache_worker() {
    rm -f "$WORK/http-a.port"
    start_worker a --http-listen 127.0.0.1:0 --http-port-file "$WORK/http-a.port"
    wait_until 15 test -s "$WORK/http-a.port"
    HTTP_A=$(cat "$WORK/http-a.port")
}

# corrupt_blobs_counted: the worker's alphorn_worker_blobs_corrupt_total.
corrupt_blobs_counted() {
    curl -sf -H "Authorization: Bearer $(cat "$WORK/worker.token")" "http://127.0.0.1:$HTTP_A/metrics" |
        awk '$1 == "alphorn_worker_blobs_corrupt_total" { print $2 }'
}

# damage_blob: overwrites 4 bytes at offset 36 of the cached mesh in place (no new inode).
damage_blob() {
    printf 'v -3' | dd of="$BLOB" bs=1 seek=36 conv=notrunc status=none
    cmp -s "$BLOB" "$MESH" && fail "the cached blob is not damaged"
    [[ $(stat -c %s "$BLOB") == $(stat -c %s "$MESH") ]] || fail "the damage changed the blob's size"
}

# render_and_compare NAME: a 64-pass seed-7 job of the scene, which must end done with the
# local render's bytes.
render_and_compare() {
    local name=$1 job
    job=$("$ALPHORN" submit "$SCENE_XML" --seed 7 --passes 64 --tile 32 2>/dev/null)
    "$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "job $job ($name) did not finish"
    [[ $(job_field "$job" state) == JOB_STATE_DONE ]] || fail "job $job ($name) is not done"
    "$ALPHORN" fetch "$job" -o "$WORK/$name.exr" 2>/dev/null || fail "fetch of job $job failed"
    cmp "$WORK/local.exr" "$WORK/$name.exr" || fail "the EXR of job $job ($name) differs from alphorn render"
}

start_coordinator
start_cache_worker
render_local "$SCENE_XML" "$WORK/local.exr" --seed 7 --passes 64
# A first job puts the mesh into the worker's cache.
first=$("$ALPHORN" submit "$SCENE_XML" --seed 7 --passes 1 --tile 32 2>/dev/null)
"$ALPHORN" watch "$first" >/dev/null 2>&1 || fail "the first job did not finish"
[[ -f $BLOB ]] || fail "the worker did not cache the mesh as $BLOB"
kill -TERM "$WORKER_PID"
wait "$WORKER_PID" || fail "the worker did not stop cleanly"

# While the worker is down, with the modification time put back: only hashing finds it.
touch -r "$BLOB" "$WORK/blob.time"
damage_blob
touch -m -r "$WORK/blob.time" "$BLOB"
[[ $(stat -c %y "$BLOB") == $(stat -c %y "$WORK/blob.time") ]] ||
    fail "the blob's modification time was not restored"
start_cache_worker
render_and_compare restarted
cmp -s "$BLOB" "$MESH" || fail "the cached blob is still damaged after the job"
[[ $(grep -c "event=blob.corrupt" "$WORK/worker-a.log") == 1 ]] ||
    fail "the worker did not log blob.corrupt once: $(grep "blob\." "$WORK/worker-a.log")"
grep "event=blob.corrupt" "$WORK/worker-a.log" | grep -q "sha256=$SHA path=blobs/$SHA size=$(stat -c %s "$MESH") .*action=refetch" ||
    fail "the blob.corrupt line lacks its fields: $(grep "event=blob.corrupt" "$WORK/worker-a.log")"
[[ $(corrupt_blobs_counted) == 1 ]] || fail "alphorn_worker_blobs_corrupt_total is $(corrupt_blobs_counted), not 1"
pass "damaged while the worker was down (size and time kept): found, fetched again, same bytes"

# While the worker runs, between two jobs; writing the bytes changes the modification time.
before=$(stat -c %y "$BLOB")
damage_blob
[[ $(stat -c %y "$BLOB") != "$before" ]] || fail "the damage left the modification time as it was"
render_and_compare running
cmp -s "$BLOB" "$MESH" || fail "the cached blob is still damaged after the second job"
[[ $(grep -c "event=blob.corrupt" "$WORK/worker-a.log") == 2 ]] || fail "the worker did not log blob.corrupt again"
[[ $(corrupt_blobs_counted) == 2 ]] || fail "alphorn_worker_blobs_corrupt_total is $(corrupt_blobs_counted), not 2"
pass "damaged while the worker ran (time changed): found, fetched again, same bytes"

# Intact, it is used as it is: no further corrupt blob, the same bytes.
render_and_compare intact
[[ $(grep -c "event=blob.corrupt" "$WORK/worker-a.log") == 2 ]] || fail "an intact blob was called corrupt"
pass "an intact cached blob is reused"
echo "PASS"
