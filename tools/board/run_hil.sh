#!/usr/bin/env bash
# run_hil.sh HOST_SIM PLAN TOUR SECONDS OUTDIR BOARD_CMD...: hardware in the loop on one machine.
# Starts `HOST_SIM hil` on a free UDP port of loopback, runs BOARD_CMD (board_hil, natively or
# under its board's QEMU) against it for SECONDS of the board's time, and keeps both ends' output
# in OUTDIR/world.txt and OUTDIR/board.txt. Exits with the board's status (the world's if the
# board succeeded and the world did not). Every wait is bounded.
set -euo pipefail
if [ $# -lt 6 ]; then
    echo "usage: run_hil.sh HOST_SIM PLAN TOUR SECONDS OUTDIR BOARD_CMD..." >&2
    exit 2
fi
host_sim=$1 plan=$2 tour=$3 secs=$4 out=$5
shift 5
mkdir -p "$out"
"$host_sim" hil --plan "$plan" --path "$tour" --listen 127.0.0.1:0 --idle-timeout 10 > "$out/world.txt" 2>&1 &
world=$!
trap 'kill $world 2>/dev/null || true' EXIT
port=
for _ in $(seq 300); do # 30 s at most for the world to start
    port=$(sed -n 's/.* on udp 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' "$out/world.txt")
    [ -n "$port" ] && break
    if ! kill -0 "$world" 2>/dev/null; then
        cat "$out/world.txt" >&2
        echo "run_hil: host_sim hil ended before it listened" >&2
        exit 1
    fi
    sleep 0.1
done
if [ -z "$port" ]; then
    echo "run_hil: host_sim hil did not listen within 30 s (see $out/world.txt)" >&2
    exit 1
fi
echo "run_hil: the world (host_sim hil) on udp 127.0.0.1:$port; the board: $*"
status=0
timeout $((secs * 4 + 60)) "$@" --connect "127.0.0.1:$port" --tour "$tour" --time "$secs" | tee "$out/board.txt" \
    || status=$?
wstatus=0
for _ in $(seq 300); do # the world ends 10 s after the board's last frame
    kill -0 "$world" 2>/dev/null || break
    sleep 0.1
done
if kill -0 "$world" 2>/dev/null; then
    echo "run_hil: host_sim hil still runs 30 s after the board ended: stopped" >&2
    kill "$world"
    wstatus=1
else
    wait "$world" || wstatus=$?
fi
tail -1 "$out/world.txt"
trap - EXIT
if [ "$status" -ne 0 ]; then
    echo "run_hil: the board failed (exit $status)" >&2
    exit "$status"
fi
exit "$wstatus"
