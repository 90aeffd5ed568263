#!/usr/bin/env bash
# The house rule of DESIGN.md section 2, checked: firmware/ includes only the C standard
# library, its own headers, hal/include and the board. Include paths already hide host_sim
# and the generated LCM code from it; this catches system headers that paths cannot hide
# (POSIX, ODE, LCM, ZMQ, GL) and heap calls. Exits 1 and lists every violation.
set -uo pipefail
cd "$(dirname "$0")/.."

std='assert|complex|ctype|errno|fenv|float|inttypes|iso646|limits|locale|math|setjmp|signal|stdalign|stdarg|stdatomic|stdbool|stddef|stdint|stdio|stdlib|stdnoreturn|string|tgmath|time|uchar|wchar|wctype'
bad=0
# Angle-bracket includes in firmware/ must be C standard headers; the one C++ shim may also
# take Eigen and the compiler's SIMD intrinsics (guarded there by the target's feature macros).
while IFS= read -r hit; do
    file=${hit%%:*}
    hdr=$(sed -E 's/.*#[[:space:]]*include[[:space:]]*<([^>]+)>.*/\1/' <<<"$hit")
    if [[ "$hdr" =~ ^($std)\.h$ ]]; then continue; fi
    if [[ "$file" == *.cpp && ( "$hdr" == Eigen/* || "$hdr" =~ ^(immintrin|arm_neon)\.h$ ) ]]; then continue; fi
    echo "layering: $hit: <$hdr> is not allowed in firmware/ (it belongs in hal/host or host_sim)"
    bad=1
done < <(grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*<' firmware --include='*.c' --include='*.h' --include='*.cpp')
# No heap in firmware/: storage is static and sized at compile time.
while IFS= read -r hit; do
    echo "layering: $hit: firmware/ must not allocate from the heap"
    bad=1
done < <(grep -rnE '\b(malloc|calloc|realloc|free|aligned_alloc|posix_memalign)[[:space:]]*\(' firmware --include='*.c' --include='*.h' --include='*.cpp' | grep -vE ':[[:space:]]*(\*|//|/\*)')
exit $bad
