#!/usr/bin/env bash
# Prometheus metrics, scraped by the real Prometheus server (Debian's /usr/bin/prometheus): a
# coordinator and two workers serve /metrics (--http-listen) with a metrics token, Prometheus
# scrapes them every second, and PromQL queries through its HTTP API must give the jobs' real
# counts: units merged = the job's units, leased = those and the audits' second leases,
# samples = width x height x passes, jobs done, photon paths traced = the photon passes built x photons per pass. /metrics without a
# token, or with a token it does not accept, is refused (401) unless --http-anonymous-metrics;
# a TLS coordinator serves it over HTTPS only.
PROMETHEUS=${PROMETHEUS:-/usr/bin/prometheus}
if [[ ! -x $PROMETHEUS ]]; then
    echo "FAIL: $PROMETHEUS is missing (tools/install-deps.sh installs the prometheus package)"
    exit 1
fi
source "$(dirname "$0")/farm_lib.sh"

openssl rand -hex 32 >"$WORK/metrics.token"
chmod 600 "$WORK"/*.token

# wait_for_file FILE: until a daemon has written its port file.
wait_for_file() {
    wait_until 15 test -s "$1"
}

start_coordinator 127.0.0.1:0 --http-listen 127.0.0.1:0 --http-port-file "$WORK/http.port" \
    --metrics-token-file "$WORK/metrics.token"
start_worker a --http-listen 127.0.0.1:0 --http-port-file "$WORK/http-a.port" \
    --metrics-token-file "$WORK/metrics.token"
# Worker b lets anyone read its /metrics, as an operator may on a trusted network.
start_worker b --http-listen 127.0.0.1:0 --http-port-file "$WORK/http-b.port" \
    --metrics-token-file "$WORK/metrics.token" --http-anonymous-metrics
for file in http.port http-a.port http-b.port; do wait_for_file "$WORK/$file"; done
HTTP=$(cat "$WORK/http.port")
HTTP_A=$(cat "$WORK/http-a.port")
HTTP_B=$(cat "$WORK/http-b.port")

# status_of URL [TOKEN]: the HTTP status code of GET URL.
status_of() {
    local auth=()
    [[ -n ${2:-} ]] && auth=(-H "Authorization: Bearer $2")
    curl -s -o /dev/null -w '%{http_code}' "${auth[@]}" "$1"
}
[[ $(status_of "http://127.0.0.1:$HTTP/metrics") == 401 ]] || fail "coordinator /metrics without a token was not refused with 401"
[[ $(status_of "http://127.0.0.1:$HTTP/metrics" "$(cat "$WORK/worker.token")") == 401 ]] ||
    fail "coordinator /metrics with the worker token was not refused with 401"
[[ $(status_of "http://127.0.0.1:$HTTP_A/metrics") == 401 ]] || fail "worker /metrics without a token was not refused with 401"
[[ $(status_of "http://127.0.0.1:$HTTP/metrics" "$(cat "$WORK/client.token")") == 200 ]] ||
    fail "coordinator /metrics refused the client token"
[[ $(status_of "http://127.0.0.1:$HTTP/nothing" "$(cat "$WORK/metrics.token")") == 404 ]] ||
    fail "an unknown path with a token was not 404"
pass "/metrics without a token (or with the worker token at the coordinator) refused: 401"
[[ $(status_of "http://127.0.0.1:$HTTP_B/metrics") == 200 ]] ||
    fail "a worker with --http-anonymous-metrics refused /metrics without a token"
[[ $(status_of "http://127.0.0.1:$HTTP_B/other") == 401 ]] ||
    fail "--http-anonymous-metrics opened more than /metrics"
pass "--http-anonymous-metrics serves /metrics, and nothing else, without a token"

# Prometheus on a free loopback port, scraping all three every second with the metrics token.
PROM_PORT=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
cat >"$WORK/prometheus.yml" <<EOF
global:
  scrape_interval: 1s
  scrape_timeout: 1s
scrape_configs:
  - job_name: alphorn-coordinator
    authorization: {type: Bearer, credentials_file: $WORK/metrics.token}
    static_configs: [{targets: ['127.0.0.1:$HTTP']}]
  - job_name: alphorn-worker
    authorization: {type: Bearer, credentials_file: $WORK/metrics.token}
    static_configs: [{targets: ['127.0.0.1:$HTTP_A', '127.0.0.1:$HTTP_B']}]
EOF
"$PROMETHEUS" --config.file="$WORK/prometheus.yml" --storage.tsdb.path="$WORK/tsdb" \
    --web.listen-address="127.0.0.1:$PROM_PORT" >"$WORK/prometheus.log" 2>&1 &
PIDS+=("$!")
API=http://127.0.0.1:$PROM_PORT/api/v1

# query PROMQL: the value of an instant query with one result ("none" when empty).
query() {
    curl -s --get --data-urlencode "query=$1" "$API/query" |
        jq -r 'if .status == "success" and (.data.result | length) == 1 then .data.result[0].value[1] else "none" end'
}
targets_up() {
    [[ $(curl -s "$API/targets" 2>/dev/null | jq '[.data.activeTargets[] | select(.health == "up")] | length' 2>/dev/null) == 3 ]]
}
wait_until 30 targets_up
pass "Prometheus scrapes the coordinator and both workers with the metrics token"

"$ALPHORN" submit "$SCENES/farm_normals.xml" --seed 3 --passes 3 --tile 32 -o "$WORK/normals.exr" \
    2>"$WORK/submit1.log" || fail "submit failed: $(cat "$WORK/submit1.log")"
"$ALPHORN" submit "$SCENES/farm_photon.xml" --seed 9 --passes 4 --tile 40 --passes-per-unit 2 \
    -o "$WORK/photon.exr" 2>"$WORK/submit2.log" || fail "submit failed: $(cat "$WORK/submit2.log")"
units=$(($(job_field 1 units_total) + $(job_field 2 units_total)))
samples=$((96 * 64 * 3 + 80 * 60 * 4))
photons=$(($(job_field 2 pass_data_builds) * 20000))
blob_bytes=0
for file in "$SCENES/farm_normals.xml" "$SCENES/farm_photon.xml" "$SCENES/../../../scenes/meshes/sphere.obj" \
    "$SCENES/../../../scenes/meshes/quad.obj"; do
    blob_bytes=$((blob_bytes + $(stat -c %s "$file")))
done

# expect PROMQL VALUE: waits until Prometheus has scraped the final value (a few seconds).
expect() {
    local got deadline=$((SECONDS + 20))
    until got=$(query "$1") && [[ $got == "$2" ]]; do
        ((SECONDS < deadline)) || fail "$1 = $got, expected $2"
        sleep 0.5
    done
    pass "$1 = $2"
}
# Audits: each worker's first unit of each job (and the audited share, which is 1% and may pick
# none of these units) is rendered by a second worker too; its first result is held, the
# second's merged. So audited units are leased, rendered and delivered twice, merged once.
audited=$(($(job_field 1 units_audited) + $(job_field 2 units_audited)))
((audited >= 1)) || fail "no unit was audited with two workers on two jobs"
expect 'alphorn_jobs{state="done"}' 2
expect 'alphorn_jobs{state="running"}' 0
expect 'alphorn_units_merged_total' "$units"
expect 'alphorn_units_leased_total' "$((units + audited))"
expect 'alphorn_units_leased_again_total' "$audited"
expect 'sum(alphorn_units_failed_total)' 0
expect 'sum(alphorn_units_audited_total)' "$audited"
expect 'alphorn_units_audited_total{outcome="agreed"}' "$audited"
expect 'alphorn_samples_merged_total' "$samples"
# The workers' samples and photons count the audits' second renders too.
expect 'sum(alphorn_worker_samples_total) > bool '"$samples" 1
expect 'sum(alphorn_worker_units_rendered_total)' "$((units + audited))"
expect 'sum(alphorn_units_merged_by_worker_total)' "$units"
expect 'sum(alphorn_worker_results_total{outcome="merged"})' "$units"
expect 'sum(alphorn_worker_results_total{outcome="held"})' "$audited"
expect 'alphorn_lease_wait_seconds_count' "$((units + audited))"
expect 'alphorn_result_seconds_count' "$units"
expect 'sum(alphorn_worker_delivery_seconds_count)' "$((units + audited))"
expect 'sum(alphorn_worker_photons_traced_total) >= bool '"$photons" 1
expect 'alphorn_pending_units' 0
expect 'alphorn_leased_units' 0
expect 'alphorn_workers{state="alive"}' 2
expect 'alphorn_blob_store_bytes' "$blob_bytes"
expect 'alphorn_blob_uploaded_bytes_total' "$blob_bytes"
# Every camera sample traces at least its primary ray; each job ends with a final checkpoint.
expect 'sum(alphorn_worker_rays_total) >= bool '"$samples" 1
expect 'alphorn_checkpoint_write_seconds_count >= bool 2' 1
expect 'alphorn_checkpoint_written_bytes_total > bool 0' 1

# With TLS the coordinator serves /metrics over HTTPS with its gRPC certificate, and only so.
openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
    -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
    -keyout "$WORK/key.pem" -out "$WORK/cert.pem" >"$WORK/openssl.log" 2>&1 || fail "openssl failed"
"$COORDINATOR" --listen 127.0.0.1:0 --state-dir "$WORK/tls-state" --client-token-file "$WORK/client.token" \
    --worker-token-file "$WORK/worker.token" --tls-cert "$WORK/cert.pem" --tls-key "$WORK/key.pem" \
    --http-listen 127.0.0.1:0 --http-port-file "$WORK/https.port" >>"$WORK/coordinator-tls.log" 2>&1 &
PIDS+=("$!")
wait_for_file "$WORK/https.port"
HTTPS=$(cat "$WORK/https.port")
curl -s --cacert "$WORK/cert.pem" -H "Authorization: Bearer $(cat "$WORK/client.token")" \
    "https://127.0.0.1:$HTTPS/metrics" | grep -q '^alphorn_jobs{state="running"} 0' ||
    fail "no metrics over HTTPS from a TLS coordinator"
code=$(curl -s -o /dev/null -w '%{http_code}' --max-time 5 -H "Authorization: Bearer $(cat "$WORK/client.token")" \
    "http://127.0.0.1:$HTTPS/metrics" || true)
[[ $code != 200 ]] || fail "a TLS coordinator served /metrics over plain HTTP"
pass "a TLS coordinator serves /metrics over HTTPS with its certificate only (plain HTTP: $code)"
echo "PASS"
