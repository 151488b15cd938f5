#!/usr/bin/env bash
# 6e (first half) and 6f: every RPC refuses a missing or wrong token, and each role's token
# works only for its own service; hostile bundle paths, oversized blobs and hash mismatches
# are refused; a malformed scene fails at submit with file and line; a scene cannot name files
# outside its bundle.
source "$(dirname "$0")/farm_lib.sh"

start_coordinator 127.0.0.1:0 --max-blob-bytes 50000
"$PROBE" auth-matrix "$ADDRESS" "$WORK/client.token" "$WORK/worker.token" >"$WORK/auth.log" 2>&1 ||
    fail "token checks: $(grep FAIL "$WORK/auth.log")"
pass "$(grep -c '^ok' "$WORK/auth.log") token checks over all 13 RPCs and 4 callers"
"$PROBE" hostile-input "$ADDRESS" "$WORK/client.token" >"$WORK/hostile.log" 2>&1 ||
    fail "hostile input: $(cat "$WORK/hostile.log")"
cat "$WORK/hostile.log"

# The CLI with a wrong token, and a worker holding the client token, are refused.
openssl rand -hex 32 >"$WORK/wrong.token"
"$ALPHORN" status --token-file "$WORK/wrong.token" 2>"$WORK/wrong.log" && fail "status with a wrong token succeeded"
grep -q "wrong token" "$WORK/wrong.log" || fail "unexpected message: $(cat "$WORK/wrong.log")"
"$WORKER" --coordinator "$ADDRESS" --token-file "$WORK/client.token" --cache-dir "$WORK/cache-x" \
    >"$WORK/worker-x.log" 2>&1 && fail "a worker with the client token was accepted"
grep -q "refused registration" "$WORK/worker-x.log" || fail "unexpected: $(cat "$WORK/worker-x.log")"
pass "CLI with a wrong token and worker with the client token are refused"

# A malformed scene through the CLI: the loader's file:line message, non-zero exit, no job.
mkdir -p "$WORK/scene"
printf '<scene>\n  <integrator type="normals"/>\n  <camera type="perspective">\n    <integer name="width" value="-5"/>\n  </camera>\n</scene>\n' >"$WORK/scene/bad.xml"
"$ALPHORN" submit "$WORK/scene/bad.xml" 2>"$WORK/bad.log" && fail "a malformed scene was accepted"
grep -q "bad.xml:[0-9]*:[0-9]*" "$WORK/bad.log" || fail "no file:line in: $(cat "$WORK/bad.log")"
pass "malformed scene refused with file:line: $(head -n1 "$WORK/bad.log")"
# A crafted bundle holding only scene.xml that names a file of the server (absolute path, "..",
# a bitmap texture) is refused at submit with file:line and the reference, and no message
# shows a server path. (Bundles cannot carry symbolic links: the wire manifest lists only
# paths and hashes and daemons materialize regular files.)
mkdir -p "$WORK/outside"
cp "$SCENES/../../../scenes/meshes/quad.obj" "$WORK/outside/quad.obj"
"$PROBE" confinement "$ADDRESS" "$WORK/client.token" "$WORK/outside/quad.obj" "$WORK/state" \
    >"$WORK/confinement.log" 2>&1 || fail "confinement: $(grep FAIL "$WORK/confinement.log")"
cat "$WORK/confinement.log"

# `alphorn submit` refuses a scene naming an absolute path before uploading anything.
mkdir -p "$WORK/absolute"
# (A comment keeps its bytes apart from the probe's scenes, which are stored.)
printf '<scene>\n  <integrator type="normals"/>  <!-- from the CLI -->\n  <camera type="perspective"/>\n  <mesh type="obj"><string name="filename" value="%s"/></mesh>\n</scene>\n' \
    "$WORK/outside/quad.obj" >"$WORK/absolute/scene.xml"
"$ALPHORN" submit "$WORK/absolute/scene.xml" 2>"$WORK/absolute.log" && fail "a scene naming an absolute path was submitted"
grep -q "scene.xml:4:.*\"$WORK/outside/quad.obj\" is an absolute path" "$WORK/absolute.log" ||
    fail "unexpected message: $(cat "$WORK/absolute.log")"
for file in "$WORK/absolute/scene.xml" "$WORK/outside/quad.obj"; do
    sha=$(sha256sum "$file" | cut -c1-64)
    [[ ! -e $WORK/state/blobs/${sha:0:2}/$sha ]] || fail "$file was uploaded for a refused scene"
done
pass "submit refuses an absolute path before uploading: $(head -n1 "$WORK/absolute.log")"

# A scene that reaches its meshes through a symbolic link is bundled with the files where the
# scene names them (the farm follows no links), so the coordinator finds them and accepts it.
mkdir -p "$WORK/project/scene" "$WORK/library"
cp "$WORK/outside/quad.obj" "$WORK/library/quad.obj"
ln -s "$WORK/library" "$WORK/project/scene/meshes"
printf '<scene>\n  <integrator type="normals"/>\n  <camera type="perspective"/>\n  <mesh type="obj"><string name="filename" value="meshes/quad.obj"/></mesh>\n</scene>\n' \
    >"$WORK/project/scene/linked.xml"
"$ALPHORN" submit "$WORK/project/scene/linked.xml" >"$WORK/linked.log" 2>&1 ||
    fail "a scene with linked meshes was refused: $(cat "$WORK/linked.log")"
pass "a scene reaching its meshes through a symbolic link is accepted"
echo "PASS"
