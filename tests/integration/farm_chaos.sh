#!/usr/bin/env bash
# Chaos: three jobs of different kinds (path tracing, progressive photon mapping, a medium) on
# three workers over TLS, under a random schedule of kill -9 and SIGSTOP/SIGCONT of workers,
# kill -9 and SIGTERM of the coordinator with restarts, a second coordinator on the same state
# directory, a watching client that disconnects and re-attaches, and a state directory that
# fills up and is freed, or fails with I/O errors or as read-only for a while. Every job's EXR must be byte-identical to its `alphorn render`, and no
# process may hang (every wait is bounded).
#
# The schedule is a function of the seed: CHAOS_SEED=N CHAOS_STEPS=K bash farm_chaos.sh replays
# it (timings differ between runs; the actions and their order do not). CI runs one short
# schedule; tools/chaos-soak.sh runs long ones with fresh seeds.
source "$(dirname "$0")/farm_lib.sh"
trap 'echo "FAIL: line $LINENO: $BASH_COMMAND exited non-zero" >&2' ERR

# CI's default schedule (seed 8, 14 steps) restarts the coordinator with several jobs resumed,
# the case that once gave a job another job's scene; soaks pass other seeds.
seed=${CHAOS_SEED:-8}
steps=${CHAOS_STEPS:-14}
RANDOM=$seed
echo "chaos seed $seed, $steps steps (replay: CHAOS_SEED=$seed CHAOS_STEPS=$steps)"
# uniform PERIOD_MS_MIN PERIOD_MS_MAX: a random number of seconds, printed as "S.mmm".
uniform() { local ms=$(($1 + RANDOM % ($2 - $1 + 1))); printf '%d.%03d' $((ms / 1000)) $((ms % 1000)); }

# The state directory lives on its own small file system so it can really fill up. Without the
# right to mount one (or with CHAOS_DISK=prlimit), a file size limit on the coordinator stands in
# for a full disk.
mkdir -p "$WORK/state"
disk_mode=prlimit
if [[ ${CHAOS_DISK:-tmpfs} == tmpfs ]] && mount -t tmpfs -o size=48m alphorn-chaos "$WORK/state" 2>/dev/null; then
    disk_mode=tmpfs
fi
trap 'st=$?; set +e; trap - ERR; for p in "${PIDS[@]}"; do kill -9 "$p" 2>/dev/null; done
      wait 2>/dev/null; [[ $disk_mode == tmpfs ]] && umount -l "$WORK/state"; (exit $st); cleanup' EXIT
echo "full-disk episodes: $disk_mode"

openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
    -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
    -keyout "$WORK/key.pem" -out "$WORK/cert.pem" >"$WORK/openssl.log" 2>&1 || fail "openssl failed"
export ALPHORN_TLS_CA="$WORK/cert.pem"
coordinator_flags=(--tls-cert "$WORK/cert.pem" --tls-key "$WORK/key.pem" --checkpoint-interval 0.5 --lease-seconds 2)
# Every coordinator runs with the preloaded library of tests/support/io_fault.cpp, which makes
# its state directory fail (EIO or EROFS) while $WORK/disk-fault exists.
start_coordinator_on() {
    LD_PRELOAD=$IO_FAULT ALPHORN_IO_FAULT_DIR="$WORK/state" ALPHORN_IO_FAULT_SWITCH="$WORK/disk-fault" \
        start_coordinator "$1" "${coordinator_flags[@]}"
}
start_coordinator_on 127.0.0.1:0
restart_coordinator() {
    start_coordinator_on "127.0.0.1:$PORT"
}

declare -A WORKER_PIDS
launch_worker() {
    ALPHORN_TEST_UNIT_DELAY_MS=150 start_worker "$1" --tls-ca "$WORK/cert.pem"
    WORKER_PIDS[$1]=$WORKER_PID
}
for w in a b c; do launch_worker $w; done

scenes=(farm_path farm_photon farm_fog)
passes=(12 8 8)
jobs=()
for i in 0 1 2; do
    render_local "$SCENES/${scenes[$i]}.xml" "$WORK/local$i.exr" --seed 3 --passes "${passes[$i]}"
    jobs+=("$("$ALPHORN" submit "$SCENES/${scenes[$i]}.xml" --seed 3 --passes "${passes[$i]}" --tile 32 \
        2>>"$WORK/submit.log")") || fail "submit ${scenes[$i]} failed"
done
pass "submitted jobs ${jobs[*]} (${scenes[*]})"

"$ALPHORN" watch "${jobs[0]}" >>"$WORK/watch.log" 2>&1 &
WATCH_PID=$!
PIDS+=("$WATCH_PID")

fill_disk() {
    if [[ $disk_mode == tmpfs ]]; then
        dd if=/dev/zero of="$WORK/state/filler" bs=1M >/dev/null 2>&1 || true
    else
        prlimit --pid "$COORDINATOR_PID" --fsize=4096: || true
    fi
}
free_disk() {
    if [[ $disk_mode == tmpfs ]]; then rm -f "$WORK/state/filler"; else prlimit --pid "$COORDINATOR_PID" --fsize=unlimited: || true; fi
}
# Disk episodes take turns, so that the schedule (a function of the seed) does not change: a full
# disk, then I/O errors (EIO), then a full disk, then a read-only file system (EROFS), ...
disk_episodes=0
disk_episode() {  # disk_episode SECONDS: sets `what`
    local held=$1 turn=$((disk_episodes++ % 4)) error=EIO
    ((turn == 3)) && error=EROFS
    case $turn in
        0 | 2)
            fill_disk
            sleep "$held"
            free_disk
            what="state directory full for $held s, freed" ;;
        1 | 3)
            echo "$error" >"$WORK/disk-fault"
            sleep "$held"
            rm -f "$WORK/disk-fault"
            what="state directory's disk failing ($error) for $held s, back" ;;
    esac
}

# stop_within SECONDS PID: waits for PID to exit; a process that does not is a hang.
stop_within() {
    local deadline=$((SECONDS + $1))
    while kill -0 "$2" 2>/dev/null; do
        ((SECONDS < deadline)) || fail "process $2 did not stop within $1 s (hang)"
        sleep 0.1
    done
    wait "$2" 2>/dev/null || true
}

names=(a b c)
for ((step = 1; step <= steps; step++)); do
    action=$((RANDOM % 7))
    w=${names[$((RANDOM % 3))]}
    pause=$(uniform 200 1500)
    case $action in
        0)
            kill -9 "${WORKER_PIDS[$w]}" 2>/dev/null || true
            wait "${WORKER_PIDS[$w]}" 2>/dev/null || true
            sleep "$(uniform 0 1000)"
            launch_worker "$w"
            what="kill -9 worker $w, restarted" ;;
        1)
            stopped=$(uniform 500 3500)  # often longer than the 2 s lease: fenced on SIGCONT
            kill -STOP "${WORKER_PIDS[$w]}" 2>/dev/null || true
            sleep "$stopped"
            kill -CONT "${WORKER_PIDS[$w]}" 2>/dev/null || true
            what="SIGSTOP worker $w for $stopped s, SIGCONT" ;;
        2)
            kill -9 "$COORDINATOR_PID"
            wait "$COORDINATOR_PID" 2>/dev/null || true
            sleep "$(uniform 0 800)"
            restart_coordinator
            what="kill -9 coordinator, restarted" ;;
        3)
            kill -TERM "$COORDINATOR_PID"
            stop_within 20 "$COORDINATOR_PID"
            restart_coordinator
            what="SIGTERM coordinator, restarted" ;;
        4)
            timeout 15 "$COORDINATOR" --listen 127.0.0.1:0 --state-dir "$WORK/state" \
                --client-token-file "$WORK/client.token" --worker-token-file "$WORK/worker.token" \
                --tls-cert "$WORK/cert.pem" --tls-key "$WORK/key.pem" >"$WORK/second.log" 2>&1 &&
                fail "a second coordinator ran on the state directory"
            grep -q "in use by another coordinator" "$WORK/second.log" ||
                fail "the second coordinator did not name the holder: $(cat "$WORK/second.log")"
            what="second coordinator on the state directory: refused" ;;
        5)
            kill -9 "$WATCH_PID" 2>/dev/null || true
            wait "$WATCH_PID" 2>/dev/null || true
            sleep "$(uniform 0 500)"
            "$ALPHORN" watch "${jobs[$((RANDOM % 3))]}" >>"$WORK/watch.log" 2>&1 &
            WATCH_PID=$!
            PIDS+=("$WATCH_PID")
            what="watching client killed and re-attached" ;;
        6)
            disk_episode "$(uniform 500 2500)" ;;
    esac
    echo "step $step: $what"
    sleep "$pause"
done

for i in 0 1 2; do
    timeout 150 "$ALPHORN" watch "${jobs[$i]}" >/dev/null 2>"$WORK/final-watch.log" ||
        fail "job ${jobs[$i]} (${scenes[$i]}) did not finish: $(tail -n2 "$WORK/final-watch.log"); status: $("$ALPHORN" status "${jobs[$i]}" 2>&1)"
    timeout 60 "$ALPHORN" fetch "${jobs[$i]}" -o "$WORK/farm$i.exr" 2>>"$WORK/fetch.log" ||
        fail "fetch of job ${jobs[$i]} failed: $(tail -n2 "$WORK/fetch.log")"
    cmp "$WORK/local$i.exr" "$WORK/farm$i.exr" || fail "job ${jobs[$i]} (${scenes[$i]}) differs from its local render (seed $seed)"
done
pass "all three jobs byte-identical to their local renders"
for w in a b c; do
    kill -0 "${WORKER_PIDS[$w]}" 2>/dev/null || fail "worker $w died: $(tail -n3 "$WORK/worker-$w.log")"
done
pass "every worker alive"
echo "PASS (seed $seed)"
