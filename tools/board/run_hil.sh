#!/usr/bin/env bash
# run_hil.sh [--link udp|serial|ether] HOST_SIM PLAN TOUR SECONDS OUTDIR BOARD_CMD...: hardware in the
# loop on one machine. Starts `HOST_SIM hil` on a free port of loopback, runs BOARD_CMD (board_hil,
# natively or under its board's QEMU) against it for SECONDS of the board's time, and keeps both
# ends' output in OUTDIR/world.txt and OUTDIR/board.txt. Exits with the board's status (the
# world's if the board succeeded and the world did not). Every wait is bounded.
#   --link udp     (default) the world on UDP; the board is given --connect 127.0.0.1:PORT
#                  --tour TOUR --time SECONDS after BOARD_CMD (a Linux board's program).
#   --link serial  the world on TCP, carrying a serial line; BOARD_CMD is complete (a Cortex-M
#                  image under qemu-system-arm, its arguments on the semihosting command line)
#                  but for @PORT@, replaced by the world's port (-serial tcp:127.0.0.1:@PORT@).
#   --link ether   the world on UDP, Ethernet frames in its datagrams; BOARD_CMD as for serial
#                  (-nic socket,udp=127.0.0.1:@PORT@,...).
set -euo pipefail
link=udp
if [ "${1:-}" = --link ]; then
    link=${2:-}
    shift 2
fi
if [ $# -lt 6 ] || { [ "$link" != udp ] && [ "$link" != serial ] && [ "$link" != ether ]; }; then
    echo "usage: run_hil.sh [--link udp|serial|ether] HOST_SIM PLAN TOUR SECONDS OUTDIR BOARD_CMD..." >&2
    exit 2
fi
host_sim=$1 plan=$2 tour=$3 secs=$4 out=$5
shift 5
mkdir -p "$out"
"$host_sim" hil --plan "$plan" --path "$tour" --link "$link" --listen 127.0.0.1:0 --idle-timeout 10 \
    > "$out/world.txt" 2>&1 &
world=$!
trap 'kill $world 2>/dev/null || true' EXIT
port=
for _ in $(seq 300); do # 30 s at most for the world to start
    port=$(sed -n 's/.* on [a-z]* 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' "$out/world.txt")
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
if [ "$link" = udp ]; then
    board=("$@" --connect "127.0.0.1:$port" --tour "$tour" --time "$secs")
else
    board=("${@//@PORT@/$port}")
fi
echo "run_hil: the world (host_sim hil) on $link 127.0.0.1:$port; the board: ${board[*]}"
status=0
timeout $((secs * 10 + 60)) "${board[@]}" | tee "$out/board.txt" || status=$?
# The board is done: the world is asked to stop (SIGINT; it prints its last line and exits 130)
# rather than left to its 10 s idle timeout; it must be gone within 10 s.
kill -INT "$world" 2>/dev/null || true
wstatus=0
for _ in $(seq 100); do
    kill -0 "$world" 2>/dev/null || break
    sleep 0.1
done
if kill -0 "$world" 2>/dev/null; then
    echo "run_hil: host_sim hil still runs 10 s after it was asked to stop: killed" >&2
    kill -9 "$world"
    wstatus=1
else
    wait "$world" || wstatus=$?
    [ "$wstatus" -eq 130 ] && wstatus=0 # stopped as asked
fi
tail -1 "$out/world.txt"
trap - EXIT
if [ "$status" -ne 0 ]; then
    echo "run_hil: the board failed (exit $status)" >&2
    exit "$status"
fi
exit "$wstatus"
