#!/usr/bin/env bash
# Workers of two builds on one farm (alphorn_worker_other_build is the worker linked with another
# build's engine fingerprint): the other build's worker joins, is shown with its fingerprint,
# is leased none of a job admitted with the coordinator's fingerprint and logs why, while a
# worker of the coordinator's build renders the job byte-identical to `alphorn render`; a job
# pinned to the other fingerprint (`submit --engine`) is rendered by the other build's worker.
source "$(dirname "$0")/farm_lib.sh"
: "${OTHER_WORKER:?}"
OTHER=00000000000b0110

start_coordinator
"$OTHER_WORKER" --coordinator "$ADDRESS" --token-file "$WORK/worker.token" --cache-dir "$WORK/cache-other" \
    --threads 1 --name other >>"$WORK/worker-other.log" 2>&1 &
PIDS+=($!)
ours=$("$ALPHORN" --version | grep -o "engine [0-9a-f]*" | cut -d' ' -f2)
[[ ${#ours} == 16 && $ours != "$OTHER" ]] || fail "alphorn --version shows no engine fingerprint: $("$ALPHORN" --version)"
registered() { "$ALPHORN" workers --json | grep -q "\"engine_fingerprint\":\"$OTHER\""; }
wait_until 20 registered
"$ALPHORN" workers | grep -q "$OTHER" || fail "alphorn workers does not show the other build's fingerprint"
pass "the other build's worker joined and is listed with its fingerprint"

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 3 --passes 4
job=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 3 --passes 4 --tile 32 2>/dev/null)
[[ $(job_field "$job" engine_fingerprint) == "$ours" ]] || fail "the job was not admitted with the coordinator's fingerprint"
wait_until 20 grep -q "event=worker.ineligible .*engine fingerprint $ours" "$WORK/worker-other.log"
sleep 1
[[ $(job_field "$job" units_done) == 0 ]] || fail "the other build's worker rendered units of the job"
pass "the other build's worker is leased nothing of the job and logs why"

start_worker a
"$ALPHORN" watch "$job" >/dev/null 2>&1 || fail "the job did not finish"
"$ALPHORN" fetch "$job" -o "$WORK/farm.exr" 2>/dev/null || fail "fetch failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs from alphorn render"
other_merged=$("$ALPHORN" workers --json | grep -o '"name":"other"[^}]*' | grep -o '"units_merged":"[0-9]*"' | grep -o '[0-9]*')
[[ $other_merged == 0 ]] || fail "the other build's worker merged $other_merged units"
pass "a worker of the coordinator's build rendered the job byte-identical"

pinned=$("$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 3 --passes 2 --tile 32 --engine "$OTHER" 2>/dev/null)
"$ALPHORN" watch "$pinned" >/dev/null 2>&1 || fail "the pinned job did not finish"
other_merged=$("$ALPHORN" workers --json | grep -o '"name":"other"[^}]*' | grep -o '"units_merged":"[0-9]*"' | grep -o '[0-9]*')
[[ $other_merged -gt 0 ]] || fail "the job pinned to the other fingerprint was not rendered by its worker"
"$ALPHORN" submit "$SCENES/farm_normals.xml" --engine not-a-fingerprint 2>"$WORK/bad.log" &&
    fail "a malformed --engine was accepted"
grep -q "16 lowercase hex digits" "$WORK/bad.log" || fail "the refusal does not say what a fingerprint is: $(cat "$WORK/bad.log")"
pass "a job pinned with --engine goes to workers of that build; a malformed one is refused"
echo "PASS"
