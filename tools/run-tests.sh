#!/usr/bin/env bash
# Runs every cmocka test program given on the command line (or found under DIR with -d DIR),
# prints each program's own output (its cmocka summary included), and ends with one line
#     N passed, N skipped, N failed
# counting test cases (a skipped case is one that cannot run here, e.g. a kernel for an
# instruction set this CPU lacks; it says why, and it is never counted as passed). A program
# that crashes or exits non-zero without a cmocka summary counts as one failed case. Exits 1 when anything failed, 0 otherwise.
#
# Each program runs under timeout(1), so one hung program fails instead of hanging the suite:
# SIGTERM after its bound, SIGKILL TEST_KILL_AFTER seconds later (default 10) if it is still
# there; both go to its whole process group, so the processes a test started go with it (the
# fleet tests put their robots in groups of their own, tests/support/fleet_procs.c, and stop
# them on the SIGTERM). A program that timed out counts as one failed case and is listed as
# "(timed out after N s)".
# The bound is TEST_TIMEOUT seconds (default 900: the slowest programs take a few tens of
# seconds alone in a release build; ASan + UBSan and a second core's other work multiply that
# several times), except tests/gp/test_pse_sim, whose run grows with its schedule count: it
# gets TEST_TIMEOUT plus one second per 10 schedules of FLEETSIM_PSE_SIM_SCHEDULES (20,000
# schedules: 900 + 2,000 s; one core runs ~20,000 a minute in a release build).
set -uo pipefail

usage() { echo "usage: $0 [-d DIR | TEST_PROGRAM...]" >&2; exit 2; }

progs=()
if [ "${1:-}" = "-d" ]; then
    [ -n "${2:-}" ] || usage
    while IFS= read -r p; do progs+=("$p"); done < <(find "$2" -type f -name 'test_*' -perm -u+x | sort)
elif [ "${1:-}" = "-h" ] || [ "${1:-}" = "--help" ]; then
    usage
else
    progs=("$@")
fi
[ ${#progs[@]} -gt 0 ] || { echo "run-tests: no test programs found" >&2; exit 1; }

# Sanitizer builds: LeakSanitizer ignores the one third-party leak listed in tests/lsan.supp
# (also in the programs the tests start). Harmless for other builds.
export LSAN_OPTIONS="suppressions=$(cd "$(dirname "$0")/.." && pwd)/tests/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
# ThreadSanitizer builds: the races it cannot see through in the uninstrumented libzmq
# (tests/tsan.supp says why).
export TSAN_OPTIONS="suppressions=$(cd "$(dirname "$0")/.." && pwd)/tests/tsan.supp${TSAN_OPTIONS:+:$TSAN_OPTIONS}"

# Cases of one cmocka verdict in a program's output: the sum over its "[  <WORD> ] N test(s)" lines.
count() { sed -n "s/^\[  $1 *\] \([0-9]\+\) test.*/\1/p" "$2" | awk '{s+=$1} END {print s+0}'; }

TEST_TIMEOUT=${TEST_TIMEOUT:-900}
TEST_KILL_AFTER=${TEST_KILL_AFTER:-10}
for v in TEST_TIMEOUT TEST_KILL_AFTER; do
    [[ ${!v} =~ ^[1-9][0-9]*$ ]] || { echo "run-tests: $v must be a whole number of seconds > 0" >&2; exit 2; }
done

# The bound of one program, in seconds (the per-program table).
bound() {
    case "$1" in
    */test_pse_sim)
        local n=${FLEETSIM_PSE_SIM_SCHEDULES:-400}
        [[ $n =~ ^[0-9]+$ ]] || n=400
        echo $((TEST_TIMEOUT + n / 10)) ;;
    *) echo "$TEST_TIMEOUT" ;;
    esac
}

passed=0 skipped=0 failed=0 broken=() times=()
for p in "${progs[@]}"; do
    echo "=== $p"
    out=$(mktemp)
    limit=$(bound "$p")
    t0=$SECONDS
    # cmocka prints its summary on stderr; keep both streams, in order.
    timeout --kill-after="$TEST_KILL_AFTER" "$limit" "$p" 2>&1 | tee "$out"
    rc=${PIPESTATUS[0]}
    # 124: timeout sent SIGTERM; 137: it had to send SIGKILL. The elapsed time tells these
    # from a program that exits 124 or is killed by something else.
    timed_out=0
    if { [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; } && [ $((SECONDS - t0)) -ge "$limit" ]; then
        timed_out=1
    fi
    np=$(count PASSED "$out") nf=$(count FAILED "$out") ns=$(count SKIPPED "$out")
    rm -f "$out"
    times+=("$((SECONDS - t0)) $p")
    passed=$((passed + np))
    failed=$((failed + nf))
    skipped=$((skipped + ns))
    # A program that timed out: the cases it finished count as they ended, the one it hung in
    # as one failed case.
    if [ "$timed_out" -eq 1 ]; then
        echo "run-tests: $p timed out after $limit s"
        failed=$((failed + 1))
        broken+=("$p (timed out after $limit s)")
        continue
    fi
    if [ "$rc" -ne 0 ] && [ "$nf" -eq 0 ]; then
        failed=$((failed + 1))
        broken+=("$p (exit $rc)")
    fi
    [ "$rc" -ne 0 ] && [ "$nf" -gt 0 ] && broken+=("$p")
done

# Where the suite's time went: the slowest programs, so a step that grows shows up in CI's log.
echo "slowest programs (s):"
printf '%s\n' "${times[@]}" | sort -rn | head -8 | sed 's/^/  /'
if [ ${#broken[@]} -gt 0 ]; then
    echo "failing programs:"
    printf '  %s\n' "${broken[@]}"
fi
echo "$passed passed, $skipped skipped, $failed failed"
[ "$failed" -eq 0 ]
