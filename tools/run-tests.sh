#!/usr/bin/env bash
# Runs every cmocka test program given on the command line (or found under DIR with -d DIR),
# prints each program's own output (its cmocka summary included), and ends with one line
#     N passed, N skipped, N failed
# counting test cases (a skipped case is one that cannot run here, e.g. a kernel for an
# instruction set this CPU lacks; it says why, and it is never counted as passed). A program
# that crashes or exits non-zero without a cmocka summary counts as one failed case. Exits 1 when anything failed, 0 otherwise.
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

passed=0 skipped=0 failed=0 broken=()
for p in "${progs[@]}"; do
    echo "=== $p"
    out=$(mktemp)
    # cmocka prints its summary on stderr; keep both streams, in order.
    "$p" 2>&1 | tee "$out"
    rc=${PIPESTATUS[0]}
    np=$(count PASSED "$out") nf=$(count FAILED "$out") ns=$(count SKIPPED "$out")
    rm -f "$out"
    passed=$((passed + np))
    failed=$((failed + nf))
    skipped=$((skipped + ns))
    if [ "$rc" -ne 0 ] && [ "$nf" -eq 0 ]; then
        failed=$((failed + 1))
        broken+=("$p (exit $rc)")
    fi
    [ "$rc" -ne 0 ] && [ "$nf" -gt 0 ] && broken+=("$p")
done

if [ ${#broken[@]} -gt 0 ]; then
    echo "failing programs:"
    printf '  %s\n' "${broken[@]}"
fi
echo "$passed passed, $skipped skipped, $failed failed"
[ "$failed" -eq 0 ]
