#!/usr/bin/env bash
# Portability check, compile only (no run needs the hardware): the AI core's math (the Eigen
# shim and its packed kernels, the pure-C reference, the BNN trainer) compiles warning-free
# with -Werror for every x86-64 level users run (v2: SSE4.2, v3: AVX2+FMA, v4: AVX-512), with
# GCC and with clang, and for aarch64 (NEON) with the cross g++. `make check-portable` calls it
# and then builds the whole tree with clang.
#
#   tools/check-portable.sh "<preprocessor flags of the build>"
# Exits 1 on the first file that does not compile, naming the compiler and -march.
set -euo pipefail

usage() {
    cat <<'EOF'
usage: tools/check-portable.sh "<preprocessor flags of the build>"

Compiles the AI core's math (firmware/ai/*.c, firmware/ai/kernels/*.c, *.cpp) with -Wall
-Wextra -Werror, compile only, for x86-64-v2, -v3 and -v4 with GCC and clang and for aarch64
(armv8-a) with the cross g++
(on an aarch64 host: armv8-a with GCC and clang). The one argument is the build's -D/-I flags,
quoted as one word; `make check-portable` passes them and then builds and tests the whole tree
with clang. Exit 0 when every file compiles, 1 on the first that does not (naming the compiler
and -march), 2 on bad usage.
EOF
}
case "${1-}" in
    -h|--help) usage; exit 0 ;;
    "") usage >&2; exit 2 ;;
    --*) echo "check-portable: unknown option '$1' (see --help)" >&2; exit 2 ;;
esac
[[ $# -eq 1 ]] || { usage >&2; exit 2; }
cd "$(dirname "$0")/.."

flags=$1
read -r -a pp <<<"$flags"
srcs=(firmware/ai/*.c firmware/ai/kernels/*.c firmware/ai/kernels/*.cpp)
warn=(-Wall -Wextra -Werror)

compile() { # compile CC CXX MARCH_FLAG...
    local cc=$1 cxx=$2; shift 2
    local f
    for f in "${srcs[@]}"; do
        case "$f" in
            *.cpp) "$cxx" -std=c++17 "${warn[@]}" -O3 "$@" "${pp[@]}" -isystem /usr/include/eigen3 \
                       -fno-exceptions -fno-rtti -c "$f" -o /dev/null ;;
            *)     "$cc" -std=c11 "${warn[@]}" -O3 "$@" "${pp[@]}" -c "$f" -o /dev/null ;;
        esac || { echo "check-portable: $f does not compile with $cxx $*" >&2; return 1; }
    done
    echo "  OK   $cc/$cxx $* (${#srcs[@]} files)"
}

case "$(uname -m)" in
    x86_64)
        for m in x86-64-v2 x86-64-v3 x86-64-v4; do
            compile gcc g++ -march=$m
            compile clang clang++ -march=$m
        done
        compile aarch64-linux-gnu-gcc aarch64-linux-gnu-g++ -march=armv8-a
        ;;
    aarch64)
        compile gcc g++ -march=armv8-a
        compile clang clang++ -march=armv8-a
        ;;
    *)
        echo "check-portable: no portability matrix for $(uname -m)" >&2
        exit 1
        ;;
esac
