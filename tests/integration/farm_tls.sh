#!/usr/bin/env bash
# 6g: TLS with a self-signed certificate made here with openssl: workers and the client
# connect and the image is byte-identical; a plaintext client is refused.
source "$(dirname "$0")/farm_lib.sh"

openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
    -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
    -keyout "$WORK/key.pem" -out "$WORK/cert.pem" >"$WORK/openssl.log" 2>&1 || fail "openssl failed"
start_coordinator 127.0.0.1:0 --tls-cert "$WORK/cert.pem" --tls-key "$WORK/key.pem"
start_worker a --tls-ca "$WORK/cert.pem"
start_worker b --tls-ca "$WORK/cert.pem"

render_local "$SCENES/farm_normals.xml" "$WORK/local.exr" --seed 8 --passes 3
"$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 8 --passes 3 --tls-ca "$WORK/cert.pem" -o "$WORK/farm.exr" \
    2>"$WORK/submit.log" || fail "submit over TLS failed: $(cat "$WORK/submit.log")"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the EXR differs over TLS"
pass "client and workers over TLS; EXR byte-identical"

timeout 20 "$ALPHORN" status 2>"$WORK/plain.log" && fail "a plaintext client was served"
pass "plaintext client refused: $(head -c 160 "$WORK/plain.log")"
ALPHORN_TLS_CA="$WORK/cert.pem" "$ALPHORN" status >/dev/null || fail "status over TLS failed"
echo "PASS"
