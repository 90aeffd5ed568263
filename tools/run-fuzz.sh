#!/usr/bin/env bash
# Runs the libFuzzer targets `make fuzz` built (tests/fuzz/README.md), one after the other:
#   1. its regression inputs (tests/fuzz/regressions/<name>/: crashers found before, fixed),
#      each once;
#   2. the fuzzer for SECONDS on a scratch copy of its corpus (tests/fuzz/corpus/<name>/ plus
#      the binary seeds gen_seeds writes with the project's encoders), so a run never grows the
#      checked-in corpus; its dictionary tests/fuzz/<name>.dict when there is one.
# Prints one line per target (executions, executions per second, coverage: edges and features
# as libFuzzer counts them, corpus size) and fails (exit 1) on any crash, sanitizer report,
# leak, input slower than 10 s (-timeout), out-of-memory, or a run past SECONDS + 120 s.
# A failing input is kept under the scratch folder; the line says how to replay it and where
# to keep it as a regression input.
#
#   tools/run-fuzz.sh --bin DIR [--seconds N] [NAME...]
# DIR holds fuzz_<name> and gen_seeds (build/fuzz-<board>-<preset>-clang/tests/fuzz); the
# names default to every fuzz_<name> in DIR.
set -uo pipefail
cd "$(dirname "$0")/.."

usage() { sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }

seconds=60 bin="" names=()
while [ $# -gt 0 ]; do
    case "$1" in
        --seconds) seconds=${2:?}; shift 2 ;;
        --bin) bin=${2:?}; shift 2 ;;
        -h|--help) usage ;;
        -*) echo "run-fuzz: unknown option '$1'" >&2; usage ;;
        *) names+=("$1"); shift ;;
    esac
done
[ -n "$bin" ] && [ -x "$bin/gen_seeds" ] || { echo "run-fuzz: no gen_seeds in '$bin' (make fuzz builds it)" >&2; exit 2; }
[[ "$seconds" =~ ^[0-9]+$ ]] && [ "$seconds" -gt 0 ] || { echo "run-fuzz: --seconds wants a positive integer" >&2; exit 2; }
if [ ${#names[@]} -eq 0 ]; then
    for f in "$bin"/fuzz_*; do [ -x "$f" ] && names+=("${f##*/fuzz_}"); done
fi
[ ${#names[@]} -gt 0 ] || { echo "run-fuzz: no fuzz targets in $bin" >&2; exit 2; }

work="$bin/run"
rm -rf "$work" && mkdir -p "$work" || exit 1
"$bin/gen_seeds" "$work/seeds" || { echo "run-fuzz: gen_seeds failed" >&2; exit 1; }

export LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"

stat() { sed -n "s/^stat::$1: *//p" "$2" | tail -1; }

failed=()
for name in "${names[@]}"; do
    prog="$bin/fuzz_$name"
    [ -x "$prog" ] || { echo "run-fuzz: no $prog" >&2; failed+=("$name (no program)"); continue; }
    dir="$work/$name"
    mkdir -p "$dir/corpus"
    for src in "tests/fuzz/corpus/$name" "$work/seeds/$name"; do
        [ -d "$src" ] && find "$src" -maxdepth 1 -type f -exec cp {} "$dir/corpus/" \;
    done
    opts=(-timeout=10 -rss_limit_mb=2048 -print_final_stats=1 "-artifact_prefix=$dir/")
    [ -f "tests/fuzz/$name.dict" ] && opts+=("-dict=tests/fuzz/$name.dict")
    why=""

    # 1. The regression inputs, each once.
    regs=()
    if [ -d "tests/fuzz/regressions/$name" ]; then
        while IFS= read -r f; do regs+=("$f"); done < <(find "tests/fuzz/regressions/$name" -type f ! -name '.*' | sort)
    fi
    if [ ${#regs[@]} -gt 0 ]; then
        timeout -k 10 120 "$prog" "${opts[@]}" "${regs[@]}" >"$dir/regressions.log" 2>&1
        rc=$?
        if [ $rc -ne 0 ]; then
            why="a regression input fails (exit $rc)"
            log="$dir/regressions.log"
        fi
    fi

    # 2. The fuzzer on the scratch corpus.
    if [ -z "$why" ]; then
        log="$dir/fuzz.log"
        timeout -k 10 $((seconds + 120)) "$prog" "${opts[@]}" -max_total_time="$seconds" "$dir/corpus" >"$log" 2>&1
        rc=$?
        case $rc in
            0) ;;
            124|137) why="still running $((seconds + 120)) s after it started (a hang)" ;;
            *) why="exit $rc" ;;
        esac
    fi

    execs=$(stat number_of_executed_units "$log")
    eps=$(stat average_exec_per_sec "$log")
    edges=$(sed -n 's/.*Loaded [0-9]* modules *(\([0-9]*\) inline 8-bit counters).*/\1/p' "$log" | head -1)
    last=$(grep -E '^#[0-9]+.*cov: [0-9]+' "$log" | tail -1)
    cov=$(sed -n 's/.*cov: \([0-9]*\).*/\1/p' <<<"$last")
    ft=$(sed -n 's/.*ft: \([0-9]*\).*/\1/p' <<<"$last")
    corp=$(sed -n 's/.*corp: \([0-9]*\/[0-9]*[A-Za-z]*\).*/\1/p' <<<"$last")
    printf 'FUZZ %-8s %10s execs %7s/s  cov %5s of %s edges  ft %6s  corpus %-12s regressions %d  %s\n' \
        "$name" "${execs:-?}" "${eps:-?}" "${cov:-?}" "${edges:-?}" "${ft:-?}" "${corp:-?}" "${#regs[@]}" \
        "${why:+FAILED: $why}"
    if [ -n "$why" ]; then
        failed+=("$name: $why")
        echo "---- $log (last 60 lines)"
        tail -n 60 "$log"
        for a in "$dir"/crash-* "$dir"/leak-* "$dir"/timeout-* "$dir"/oom-* "$dir"/slow-unit-*; do
            [ -e "$a" ] || continue
            echo "---- failing input: $a"
            echo "     replay: $prog $a"
            echo "     keep it once fixed: cp $a tests/fuzz/regressions/$name/"
        done
    fi
done

if [ ${#failed[@]} -gt 0 ]; then
    echo "fuzz: ${#failed[@]} of ${#names[@]} targets failed:"
    printf '  %s\n' "${failed[@]}"
    exit 1
fi
echo "fuzz: ${#names[@]} targets, ${seconds} s each, no crash"
