#!/usr/bin/env bash
# The house rule, checked (docs/architecture.md, "Layers"): firmware/ and hal/common/ (the code
# every board runs) include only the C standard library, their own headers, hal/include and
# the board. Include paths already hide host_sim and the generated LCM code from them; this
# catches what paths cannot hide:
#   - system headers (POSIX, ODE, LCM, ZMQ, GL),
#   - heap calls (storage is static and sized at compile time),
#   - host services named by symbol even though their header is standard C (files, console,
#     wall-clock time, signals, process exit, environment, threads): on a board those go
#     through the HAL (storage, log, clock, core operations).
# The one generated header firmware/ includes, msg/msg_layout.h (tools/lcmgen.py, in the build
# folder), is macros and <stdint.h> only: tests/tools/test_lcmgen.py checks it, not this script.
# Exits 1 and lists every violation.
#
#   tools/check-layering.sh        (`make layering`; --help: this text)
set -uo pipefail
case "${1-}" in
    -h|--help)
        sed -n '2,/^set /{/^set /d;s/^# \{0,1\}//;p}' "$0"
        exit 0 ;;
    "") ;;
    *) echo "check-layering: takes no arguments, not '$1' (see --help)" >&2; exit 2 ;;
esac
cd "$(dirname "$0")/.."

dirs=(firmware hal/common)
src=(--include='*.c' --include='*.h' --include='*.cpp')
std='assert|complex|ctype|errno|fenv|float|inttypes|iso646|limits|locale|math|setjmp|signal|stdalign|stdarg|stdatomic|stdbool|stddef|stdint|stdio|stdlib|stdnoreturn|string|tgmath|time|uchar|wchar|wctype'
# A hit on a comment line (one that starts with *, // or /*) is prose, not a call.
code_only() { grep -vE ':[0-9]+:[[:space:]]*(\*|//|/\*)'; }
bad=0
# Angle-bracket includes must be C standard headers; the one C++ shim may also take Eigen, and
# the shim and the per-ISA kernels (firmware/ai/kernels/: la_packed_*.c, q8_*.c, la_bf16_*.c,
# ai_rng_x86.c; firmware/common/crc32_x86.c) the compiler's SIMD intrinsics (guarded there by
# the target's architecture macros).
while IFS= read -r hit; do
    file=${hit%%:*}
    hdr=$(sed -E 's/.*#[[:space:]]*include[[:space:]]*<([^>]+)>.*/\1/' <<<"$hit")
    if [[ "$hdr" =~ ^($std)\.h$ ]]; then continue; fi
    if [[ "$file" == *.cpp && "$hdr" == Eigen/* ]]; then continue; fi
    k=firmware/ai/kernels
    if [[ ( "$file" == *.cpp || "$file" == $k/la_packed_*.c || "$file" == $k/q8_*.c || "$file" == $k/la_bf16_*.c || "$file" == $k/ai_rng_x86.c || "$file" == firmware/common/crc32_x86.c ) && "$hdr" =~ ^(immintrin|arm_neon)\.h$ ]]; then continue; fi
    echo "layering: $hit: <$hdr> is not allowed here (it belongs in hal/host or host_sim)"
    bad=1
done < <(grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*<' "${dirs[@]}" "${src[@]}")
while IFS= read -r hit; do
    echo "layering: $hit: no heap here: storage is static and sized at compile time"
    bad=1
done < <(grep -rnE '\b(malloc|calloc|realloc|free|aligned_alloc|posix_memalign)[[:space:]]*\(' "${dirs[@]}" "${src[@]}" | code_only)
host='fopen|freopen|fclose|fread|fwrite|fgetc|fgets|fputc|fputs|fprintf|printf|vprintf|vfprintf|puts|putchar|getchar|scanf|fscanf|perror|fflush|setvbuf|tmpfile|tmpnam|remove|rename|time|clock|difftime|mktime|localtime|gmtime|strftime|clock_gettime|signal|raise|exit|_Exit|quick_exit|atexit|abort|system|getenv|thrd_[a-z_]+|mtx_[a-z_]+|cnd_[a-z_]+|pthread_[a-z_]+|sleep|usleep|nanosleep'
while IFS= read -r hit; do
    sym=$(grep -oE "\\b($host)[[:space:]]*\\(" <<<"${hit#*:*:}" | head -1 | tr -d ' (')
    echo "layering: $hit: $sym() is a host service; use the HAL (storage, log, clock, core)"
    bad=1
done < <(grep -rnE "(^|[^._>[:alnum:]])($host)[[:space:]]*\\(" "${dirs[@]}" "${src[@]}" | code_only)
exit $bad
