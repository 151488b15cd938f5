#!/bin/bash
# The image's HEALTHCHECK. One image serves both daemons, so it looks at which one this container
# runs and checks that one for real:
#  - coordinator: a ClientService call (ListWorkers) with the client token, so "healthy" means the
#    gRPC server answers and accepts its token, not merely that the process exists;
#  - worker: it holds an established TCP connection to the coordinator's port. Workers have no
#    inbound port and must not hold the client token, and gRPC keeps the connection open while
#    the worker polls for work and heartbeats, so this is what "connected to its farm" means.
set -euo pipefail

daemon=""
pids=()
for exe in /proc/[0-9]*/exe; do
    case $(readlink "$exe" 2>/dev/null) in
        */alphorn-coordinator) daemon=coordinator; break ;;
        */alphorn-worker) daemon=worker; pid=${exe#/proc/}; pids+=("${pid%/exe}") ;;
    esac
done

case $daemon in
coordinator)
    : "${ALPHORN_COORDINATOR:=127.0.0.1:7700}" "${ALPHORN_TOKEN_FILE:=/run/secrets/client_token}"
    export ALPHORN_COORDINATOR ALPHORN_TOKEN_FILE
    exec alphorn workers --reconnect-seconds 5 >/dev/null  # fail within the check's timeout
    ;;
"")
    echo "no alphorn daemon runs in this container"
    exit 1
    ;;
esac

# Worker: the coordinator's port, as hex, as /proc/net/tcp* prints it.
address=${ALPHORN_COORDINATOR:?the worker container needs ALPHORN_COORDINATOR (host:port)}
port=$(printf '%04X' "${address##*:}")
# The socket inodes the worker holds, then a connection in state 01 (ESTABLISHED) to that port
# owned by one of them (with host networking /proc/net/tcp shows the whole host's sockets).
inodes=" "
for pid in "${pids[@]}"; do
    for fd in /proc/"$pid"/fd/*; do
        link=$(readlink "$fd" 2>/dev/null) || continue
        [[ $link == socket:\[*\] ]] && { link=${link#socket:[}; inodes+="${link%]} "; }
    done
done
while read -r _ _ remote state _ _ _ _ _ inode _; do
    [[ $state == 01 && ${remote##*:} == "$port" && $inodes == *" $inode "* ]] && exit 0
done < <(cat /proc/net/tcp /proc/net/tcp6 2>/dev/null)
echo "the worker has no connection to the coordinator at $address"
exit 1
