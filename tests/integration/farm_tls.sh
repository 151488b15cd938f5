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

# A second coordinator given files it cannot serve TLS with says which file and why; before, every
# case read "cannot listen on ADDRESS", which blames the address.
openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=other" -keyout "$WORK/other_key.pem" \
    -out "$WORK/other_cert.pem" >>"$WORK/openssl.log" 2>&1 || fail "openssl failed"
bad_tls() {  # bad_tls CERT KEY EXPECTED_MESSAGE
    local status=0
    timeout 20 "$COORDINATOR" --listen 127.0.0.1:0 --state-dir "$WORK/state-bad" \
        --client-token-file "$WORK/client.token" --worker-token-file "$WORK/worker.token" \
        --tls-cert "$1" --tls-key "$2" >"$WORK/bad_tls.log" 2>&1 || status=$?
    ((status == 1)) || fail "a coordinator with --tls-cert $1 --tls-key $2 exited with $status, not 1"
    grep -qF -- "$3" "$WORK/bad_tls.log" || fail "no \"$3\" in: $(tail -n 1 "$WORK/bad_tls.log")"
}
bad_tls "$WORK/cert.pem" "$WORK/other_key.pem" \
    "other_key.pem: the private key does not belong to the first certificate of $WORK/cert.pem"
bad_tls "$WORK/key.pem" "$WORK/key.pem" "key.pem: holds no PEM certificate"
bad_tls "$WORK/cert.pem" "$WORK/cert.pem" "cert.pem: holds no unencrypted PEM private key"
pass "a coordinator refuses a certificate or key it cannot use, naming the file"
echo "PASS"
