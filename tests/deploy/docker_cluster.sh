#!/usr/bin/env bash
# deploy/ for real: starts a Docker engine of its own, builds deploy/Dockerfile, brings up
# deploy/docker-compose.yml (a coordinator and workers, with the host-networking override),
# submits a scene from the host with the CLI, and checks the EXR is byte-identical to a local
# `alphorn render`. Also: the containers' health checks report healthy, the daemons run as
# UID 10001 under docker-init, `--scale worker=3` adds workers, a killed worker's container is
# restarted, and a new coordinator container finds the finished job in the named volume.
#
# Exit 77 (ctest: skipped) with one line saying why when no Docker engine can be started here
# (not root, no apt-get, dockerd refuses to run). Under CI (CI=true: root, apt, a fresh
# Debian 12 machine) those are failures instead, because CI is where this test must run.
#
# The engine runs without bridge networking (no registry is reachable and only loopback may be
# used): --bridge=none and no iptables; builds and containers use the host's network stack, and
# the coordinator listens on 127.0.0.1 only.
set -euo pipefail

: "${ALPHORN:?}" "${SOURCE_DIR:?}" "${SCENES:?}"
DEPLOY=$SOURCE_DIR/deploy
# Persistent engine state (base image, layer cache, the build's ccache and apt cache mounts), so
# a second run does not rebuild from nothing. A lock serialises runs that share it.
DOCKER_ROOT=${ALPHORN_DOCKER_ROOT:-/var/lib/alphorn-test-docker}
# Debian's client, which matches Debian's engine; PATH may hold another docker.
DOCKER=/usr/bin/docker
PROJECT=alphorn-test-$$
IMAGE=alphorn:latest

started=$SECONDS
phase_start=$SECONDS
WORK=""
RUN_DIR=""
DOCKERD_PID=""
COMPOSE_UP=""
POLICY_RC=""

cannot_run() {
    if [[ ${CI:-} == true ]]; then
        echo "FAIL: $* (CI must run this test)"
        exit 1
    fi
    echo "SKIP: $*"
    exit 77
}
fail() { echo "FAIL: $*" >&2; exit 1; }
# phase NAME: prints how long the phase that just ended took, so the test reports its timing.
phase() {
    echo "ok   $1 ($((SECONDS - phase_start)) s)"
    phase_start=$SECONDS
}

compose() {
    docker-compose -p "$PROJECT" -f "$DEPLOY/docker-compose.yml" -f "$DEPLOY/docker-compose.hostnet.yml" "$@"
}

stop_dockerd() {
    [[ -n $DOCKERD_PID ]] || return 0
    kill "$DOCKERD_PID" 2>/dev/null || true
    for _ in $(seq 300); do kill -0 "$DOCKERD_PID" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$DOCKERD_PID" 2>/dev/null; then
        echo "dockerd did not stop in 30 s; killing it"
        kill -9 "$DOCKERD_PID" 2>/dev/null || true
    fi
    wait "$DOCKERD_PID" 2>/dev/null || true
    # dockerd stops the containerd it started; after a SIGKILL that containerd would be orphaned.
    local containerd_pidfile=$RUN_DIR/exec/containerd/containerd.pid
    if [[ -s $containerd_pidfile ]] && kill -0 "$(cat "$containerd_pidfile")" 2>/dev/null; then
        kill "$(cat "$containerd_pidfile")" 2>/dev/null || true
    fi
    DOCKERD_PID=""
}

cleanup() {
    local status=$?
    trap - EXIT
    if [[ -n $COMPOSE_UP ]]; then
        if [[ $status -ne 0 ]]; then
            echo "---- docker-compose logs"
            compose logs --no-color --tail 30 2>&1 || true
        fi
        compose down -v --timeout 20 >/dev/null 2>&1 || true
    fi
    stop_dockerd
    [[ -n $POLICY_RC ]] && rm -f /usr/sbin/policy-rc.d
    if [[ $status -ne 0 && $status -ne 77 && -n $WORK ]]; then
        for log in "$WORK"/*.log; do [[ -f $log ]] && { echo "== $log"; tail -n 30 "$log"; }; done
    fi
    [[ -n $WORK ]] && rm -rf "$WORK"
    if [[ $RUN_DIR == /tmp/alphorn-dockerd-?* ]]; then
        # dockerd leaves its default network namespace mounted under exec-root (and only mounts
        # under this very directory may be touched, hence the pattern above).
        awk -v dir="$RUN_DIR/" 'index($2, dir) == 1 { print $2 }' /proc/mounts | sort -r |
            while read -r mount; do umount "$mount" || true; done
        rm -rf "$RUN_DIR" || status=1
    fi
    exit "$status"
}
trap cleanup EXIT
# A command that fails outside an explicit check ends the script under `set -e`: say which.
trap 'echo "FAIL: line $LINENO: \"$BASH_COMMAND\" exited with status $?" >&2' ERR

[[ $(id -u) -eq 0 ]] || cannot_run "not root: this test installs packages and starts its own Docker engine"
command -v flock >/dev/null || cannot_run "no flock"
WORK=$(mktemp -d /tmp/alphorn-docker-test-XXXXXX)

missing=()
for p in docker.io docker-compose debootstrap; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -gt 0 ]]; then
    command -v apt-get >/dev/null || cannot_run "no apt-get to install ${missing[*]}"
    # Keep the package's own docker.service from starting: it would bring up a bridge-networked
    # system engine next to the one this test controls.
    if [[ ! -e /usr/sbin/policy-rc.d ]]; then
        printf '#!/bin/sh\nexit 101\n' >/usr/sbin/policy-rc.d && chmod +x /usr/sbin/policy-rc.d && POLICY_RC=1
    fi
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        "${missing[@]}"; } >"$WORK/apt.log" 2>&1 ||
        cannot_run "apt-get could not install ${missing[*]}: $(tail -n1 "$WORK/apt.log")"
    [[ -n $POLICY_RC ]] && rm -f /usr/sbin/policy-rc.d && POLICY_RC=""
    phase "installed ${missing[*]}"
fi

mkdir -p "$DOCKER_ROOT"
exec 9>"$DOCKER_ROOT.lock"
flock -w 900 9 || fail "another run has held $DOCKER_ROOT.lock for 15 minutes"
((SECONDS - phase_start < 2)) || phase "waited for another run to release $DOCKER_ROOT.lock"
# exec-root holds containerd's sockets: a short path stays under the unix socket length limit.
RUN_DIR=$(mktemp -d /tmp/alphorn-dockerd-XXXXXX)
dockerd --data-root "$DOCKER_ROOT" --exec-root "$RUN_DIR/exec" --pidfile "$RUN_DIR/dockerd.pid" \
    -H "unix://$RUN_DIR/docker.sock" --bridge=none --iptables=false --ip-masq=false --ip6tables=false \
    >"$WORK/dockerd.log" 2>&1 9>&- &
DOCKERD_PID=$!
export DOCKER_HOST=unix://$RUN_DIR/docker.sock
for _ in $(seq 300); do
    "$DOCKER" version >/dev/null 2>&1 && break
    kill -0 "$DOCKERD_PID" 2>/dev/null || break
    sleep 0.1
done
if ! "$DOCKER" version >/dev/null 2>&1; then
    reason=$(grep -iE 'level=(fatal|error)|failed' "$WORK/dockerd.log" | tail -n1 | cut -c1-200)
    stop_dockerd
    cannot_run "dockerd did not start: ${reason:-no reason in its log}"
fi
phase "dockerd $("$DOCKER" version -f '{{.Server.Version}}') started (pid $DOCKERD_PID)"

# No registry is reachable: the base image comes from the configured Debian mirror.
if ! "$DOCKER" image inspect debian:bookworm-slim >/dev/null 2>&1; then
    mirror=$(awk '/^URIs:/ { print $2; exit }' /etc/apt/sources.list.d/debian.sources 2>/dev/null || true)
    debootstrap --variant=minbase bookworm "$WORK/rootfs" ${mirror:+"$mirror"} >"$WORK/debootstrap.log" 2>&1 ||
        fail "debootstrap failed"
    # The host's Debian sources (with updates and security), so the image gets the same package
    # versions as a host build: the same-bytes check below compares the two.
    if [[ -f /etc/apt/sources.list.d/debian.sources ]]; then
        rm -f "$WORK/rootfs/etc/apt/sources.list"
        cp /etc/apt/sources.list.d/debian.sources "$WORK/rootfs/etc/apt/sources.list.d/"
    fi
    # Like the published slim image: no downloaded packages or package lists.
    rm -rf "$WORK"/rootfs/var/cache/apt/archives/*.deb "$WORK"/rootfs/var/lib/apt/lists/*
    tar -C "$WORK/rootfs" -c . | "$DOCKER" import - debian:bookworm-slim >/dev/null
    rm -rf "$WORK/rootfs"
    phase "base image debian:bookworm-slim made by debootstrap"
fi

# Seed the image build's ccache (a BuildKit cache mount) with the host's: tools/run-tests.sh
# has just compiled the same files with the same compiler and flags, and with SRC set to this
# checkout's path the image's compile commands are the same too, so about a hundred files are
# not compiled a second time on two cores. A build context of the ccache directory itself
# carries it in; an empty or missing one just means a full build.
if [[ -n ${CCACHE_DIR:-} && -d $CCACHE_DIR ]]; then
    printf '%s\n' 'FROM debian:bookworm-slim' \
        'RUN --mount=type=cache,id=alphorn-ccache,target=/ccache --mount=type=bind,target=/seed cp -a /seed/. /ccache/' |
        DOCKER_BUILDKIT=1 "$DOCKER" build --network host --progress plain -f - "$CCACHE_DIR" >"$WORK/seed.log" 2>&1 ||
        fail "seeding the build's ccache from $CCACHE_DIR failed"
    phase "ccache of the image build seeded from $CCACHE_DIR ($(du -sh "$CCACHE_DIR" | cut -f1))"
fi
DOCKER_BUILDKIT=1 "$DOCKER" build --network host --progress plain -f "$DEPLOY/Dockerfile" -t "$IMAGE" \
    --build-arg SRC="$SOURCE_DIR" --build-arg LANG="${LANG:-C.UTF-8}" \
    "$SOURCE_DIR" >"$WORK/build.log" 2>&1 || fail "docker build failed"
ccache_line=$(grep -Eo 'Hits: +[0-9]+ / +[0-9]+' "$WORK/build.log" | tr -s ' ' || true)
phase "image $IMAGE built (ccache ${ccache_line:-not run: compile layer cached})"

# Tokens as files, readable only by the image's user (UID 10001), as the compose file documents.
mkdir -p "$WORK/secrets"
for t in client worker; do
    openssl rand -hex 32 >"$WORK/secrets/$t.token"
    chown 10001 "$WORK/secrets/$t.token"
    chmod 400 "$WORK/secrets/$t.token"
done
PORT=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ALPHORN_SECRETS_DIR=$WORK/secrets ALPHORN_PORT=$PORT ALPHORN_WORKER_THREADS=1
export ALPHORN_COORDINATOR=127.0.0.1:$PORT ALPHORN_TOKEN_FILE=$WORK/secrets/client.token

# What users run (docker-compose.yml with docker-compose.override.yml) cannot start on this
# engine (no bridge networking), but it must at least be a valid compose file.
(cd "$DEPLOY" && docker-compose config -q) || fail "docker-compose.yml + docker-compose.override.yml do not validate"

COMPOSE_UP=1
compose up -d --no-build >"$WORK/compose-up.log" 2>&1 || fail "docker-compose up failed"

# wait_for SECONDS WHAT COMMAND...: polls until the command succeeds.
wait_for() {
    local deadline=$((SECONDS + $1)) what=$2
    shift 2
    until "$@"; do
        ((SECONDS < deadline)) || fail "timed out waiting for $what"
        sleep 0.5
    done
}
workers_registered() { [[ $("$ALPHORN" workers --json 2>/dev/null | grep -o '"worker_id"' | wc -l) -ge $1 ]]; }
# The highest worker id the coordinator ever gave (a restarted worker registers anew).
max_worker_id() {
    "$ALPHORN" workers --all --json | grep -Eo '"worker_id":"?[0-9]+' | grep -Eo '[0-9]+$' | sort -n | tail -n1
}
worker_id_reached() { [[ $(max_worker_id 2>/dev/null) -ge $1 ]]; }
# all_healthy N: N containers of this project, each reported healthy by its HEALTHCHECK.
all_healthy() {
    local ids
    mapfile -t ids < <("$DOCKER" ps -q --filter "label=com.docker.compose.project=$PROJECT")
    [[ ${#ids[@]} -eq $1 ]] || return 1
    ! "$DOCKER" inspect -f '{{.State.Health.Status}}' "${ids[@]}" | grep -qv '^healthy$'
}

wait_for 60 "two workers registered" workers_registered 2
phase "compose up: coordinator and 2 workers registered"
wait_for 90 "three healthy containers" all_healthy 3
phase "health checks: coordinator and workers healthy"
coordinator_id=$(compose ps -q coordinator)
[[ $("$DOCKER" exec "$coordinator_id" id -u) == 10001 ]] || fail "the coordinator does not run as UID 10001"
[[ $("$DOCKER" exec "$coordinator_id" cat /proc/1/comm) == docker-init ]] || fail "PID 1 is not docker-init (init: true)"

compose up -d --no-build --scale worker=3 >>"$WORK/compose-up.log" 2>&1 || fail "--scale worker=3 failed"
wait_for 60 "a third worker" workers_registered 3
phase "--scale worker=3: three workers registered"

# restart: a worker that dies (its container's init exits with it) is started again and registers.
# The exec's own shell dies with the container when the kill lands first, so its exit status
# says nothing (it failed this script under `set -e` once); the restart is checked below.
worker_id=$(compose ps -q worker | head -n1)
# shellcheck disable=SC2016  # expanded by bash inside the container
"$DOCKER" exec "$worker_id" bash -c 'for exe in /proc/[0-9]*/exe; do
    [[ $(readlink "$exe") == */alphorn-worker ]] && { pid=${exe#/proc/}; kill -KILL "${pid%/exe}"; }; done' ||
    true
wait_for 60 "the killed worker to come back" worker_id_reached 4
[[ $("$DOCKER" inspect -f '{{.RestartCount}}' "$worker_id") -ge 1 ]] || fail "the worker container was not restarted"
phase "restart policy: a killed worker's container restarted and registered again"

"$ALPHORN" render "$SCENES/farm_area_light.xml" --seed 5 --passes 6 --threads 2 -o "$WORK/local.exr" \
    >"$WORK/local.log" 2>&1 || fail "local render failed"
"$ALPHORN" submit "$SCENES/farm_area_light.xml" --seed 5 --passes 6 --tile 24 -o "$WORK/farm.exr" \
    2>"$WORK/submit.log" || fail "submit to the compose farm failed"
cmp "$WORK/local.exr" "$WORK/farm.exr" || fail "the compose farm's EXR differs from alphorn render"
phase "submit from the host: EXR byte-identical to alphorn render"

# The coordinator's state lives in the named volume, not in its container.
compose rm -s -f coordinator >>"$WORK/compose-up.log" 2>&1 || fail "removing the coordinator failed"
compose up -d --no-build --scale worker=3 coordinator >>"$WORK/compose-up.log" 2>&1 ||
    fail "recreating the coordinator failed"
job_known() { "$ALPHORN" status 1 >/dev/null 2>&1; }
wait_for 60 "the new coordinator" job_known
"$ALPHORN" fetch 1 -o "$WORK/refetched.exr" 2>"$WORK/fetch.log" || fail "fetch from the new coordinator failed"
cmp "$WORK/local.exr" "$WORK/refetched.exr" || fail "the job's image differs after recreating the coordinator"
phase "a new coordinator container serves the job from the named volume"

compose down -v --timeout 20 >"$WORK/compose-down.log" 2>&1 || fail "docker-compose down failed"
COMPOSE_UP=""
[[ -z $("$DOCKER" ps -aq --filter "label=com.docker.compose.project=$PROJECT") ]] || fail "containers left after down"
stop_dockerd
phase "down; dockerd stopped"
echo "PASS in $((SECONDS - started)) s"
