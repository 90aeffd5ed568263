#!/usr/bin/env bash
# Installs the Debian packages fleetsim builds and runs with.
#
# Idempotent and cheap on a ready machine: it first looks for one file per package and
# returns at once when all are there. Otherwise, as root, it runs `apt-get update` once and
# installs only what is missing; as another user it prints the exact command and exits 1.
#
#   tools/install-deps.sh             check, install what is missing
#   tools/install-deps.sh --check     check only; list what is missing, exit 1 if anything is
#   tools/install-deps.sh --portable  also the compilers of `make check-portable` (clang, the
#                                     aarch64 cross g++); combines with --check
#   tools/install-deps.sh --cross     also the boards' toolchains and emulators (make cross,
#                                     run-board: arm-none-eabi with newlib, aarch64, QEMU) and
#                                     cmocka for arm64 (the rpi3 board's cross test), which
#                                     needs Debian's arm64 multiarch: `dpkg --add-architecture
#                                     arm64` is run first when a missing package is :arm64
#   tools/install-deps.sh --fuzz      also clang and its runtime libraries (libFuzzer, ASan,
#                                     UBSan: Debian ships them apart from the compiler), for
#                                     `make fuzz`
#   tools/install-deps.sh --slurm     also SLURM (slurmctld, slurmd, the clients) and munge, for
#                                     `make test-slurm` (a one-node cluster on this machine)
# Every call also makes build/pyenv, a venv over Debian's python3 (--system-site-packages: numpy
# and matplotlib stay), with the PyPI packages of tools/requirements-mcap.txt (tools/fleet_mcap.py's
# MCAP export); a failure there only warns: nothing else needs them.
set -euo pipefail

# package  file-that-proves-it-is-installed
deps=(
    "build-essential      /usr/bin/g++"
    "pkg-config           /usr/bin/pkg-config"
    "libode-dev           /usr/include/ode/ode.h"
    "liblcm-dev           /usr/include/lcm/lcm.h"
    "liblcm-bin           /usr/bin/lcm-gen"
    "libzmq3-dev          /usr/include/zmq.h"
    "libsodium-dev        /usr/include/sodium.h"
    # the keyed fleet's long datagrams: OpenSSL's Poly1305 (hal_host_auth.c)
    "libssl-dev           /usr/include/openssl/evp.h"
    "libeigen3-dev        /usr/include/eigen3/Eigen/Core"
    "libosmesa6-dev       /usr/include/GL/osmesa.h"
    "libcmocka-dev        /usr/include/cmocka.h"
    "libpng-dev           /usr/include/png.h"
    # bench_bnn's GEMM comparison only (`make bench`); the firmware never links it
    "libopenblas-dev      /usr/include/$(uname -m)-linux-gnu/cblas-openblas.h"
    # every build: tools/lcmgen.py makes the messages' layouts from firmware/msg/*.lcm
    "python3              /usr/bin/python3"
    "python3-numpy        /usr/lib/python3/dist-packages/numpy/__init__.py"
    "python3-scipy        /usr/lib/python3/dist-packages/scipy/__init__.py"
    "python3-matplotlib   /usr/lib/python3/dist-packages/matplotlib/__init__.py"
    # tools/explore_figures.py: explore.gif (matplotlib's frames written by Pillow)
    "python3-pil          /usr/lib/python3/dist-packages/PIL/__init__.py"
    # build/pyenv (below): Debian's python3 makes venvs only with it
    "python3-venv         /usr/share/doc/python3-venv/copyright"
    # the fleet under the kernel's packet loss (tests/faults, make test-faults)
    "iproute2             /sbin/ip"
    "iptables             /usr/sbin/iptables"
)
# Other compilers, for the portability checks only (users of `make run` do not need them).
portable_deps=(
    "clang                  /usr/bin/clang"
    "g++-aarch64-linux-gnu  /usr/bin/aarch64-linux-gnu-g++"
)

# The fuzz targets of `make fuzz`: clang with -fsanitize=fuzzer,address,undefined. Debian 12's
# clang (14) does not pull its runtime libraries in without the recommended packages.
fuzz_deps=(
    "clang               /usr/bin/clang"
    "libclang-rt-14-dev  /usr/lib/llvm-14/lib/clang/14.0.6/lib/linux/libclang_rt.fuzzer-$(uname -m).a"
)

# The cross boards' toolchains and emulators (make cross, run-board, profile-board).
cross_deps=(
    "gcc-arm-none-eabi        /usr/bin/arm-none-eabi-gcc"
    "libnewlib-arm-none-eabi  /usr/lib/arm-none-eabi/lib/librdimon.a"
    "qemu-system-arm          /usr/bin/qemu-system-arm"
    "g++-aarch64-linux-gnu    /usr/bin/aarch64-linux-gnu-g++"
    "qemu-user                /usr/bin/qemu-aarch64"
    "libcmocka-dev:arm64      /usr/lib/aarch64-linux-gnu/libcmocka.so"
)

# SLURM and its authentication, for `make test-slurm` (tools/slurm/test-slurm.sh). Debian's
# packages enable their systemd services; the test starts its own daemons instead.
slurm_deps=(
    "slurm-wlm  /usr/sbin/slurmctld"
    "slurmd     /usr/sbin/slurmd"
    "munge      /usr/sbin/munged"
)

check_only=0
for arg in "$@"; do
    case "$arg" in
        --check) check_only=1 ;;
        --portable) deps+=("${portable_deps[@]}") ;;
        --cross) deps+=("${cross_deps[@]}") ;;
        --fuzz) deps+=("${fuzz_deps[@]}") ;;
        --slurm) deps+=("${slurm_deps[@]}") ;;
        -h|--help) sed -n '2,24p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "install-deps: unknown option '$arg' (see --help)" >&2; exit 2 ;;
    esac
done

# build/pyenv: the venv of tools/fleet_mcap.py (mcap, foxglove-schemas-protobuf, protobuf from PyPI,
# pinned). Debian's python is externally managed, so not into it. Ready when every package imports.
root=$(cd "$(dirname "$0")/.." && pwd)
pyenv_step() {
    local py="$root/build/pyenv/bin/python3" req="$root/tools/requirements-mcap.txt"
    "$py" -c 'import mcap.writer, foxglove_schemas_protobuf, google.protobuf' 2>/dev/null && return 0
    local cmd="/usr/bin/python3 -m venv --system-site-packages build/pyenv && build/pyenv/bin/pip install -r tools/requirements-mcap.txt"
    if [ "$check_only" -eq 1 ]; then
        echo "install-deps: missing the MCAP export's Python packages (build/pyenv): $cmd" >&2
        return 1
    fi
    echo "install-deps: build/pyenv: mcap, foxglove-schemas-protobuf, protobuf (tools/requirements-mcap.txt)"
    if ! { /usr/bin/python3 -m venv --system-site-packages "$root/build/pyenv" &&
           "$root/build/pyenv/bin/pip" install -q --disable-pip-version-check -r "$req"; }; then
        echo "install-deps: WARNING: build/pyenv not made (tools/fleet_mcap.py will not run): $cmd" >&2
    fi
    return 0
}

missing=()
for d in "${deps[@]}"; do
    read -r pkg file <<<"$d"
    [ -e "$file" ] || missing+=("$pkg")
done
if [ ${#missing[@]} -eq 0 ]; then
    pyenv_step
    exit $?
fi

if [ "$check_only" -eq 1 ]; then
    echo "install-deps: missing Debian packages: ${missing[*]}" >&2
    exit 1
fi

# Packages of another architecture (pkg:arch) need it added to dpkg first (multiarch).
foreign=()
known=" $(dpkg --print-foreign-architectures | tr '\n' ' ') "
for pkg in "${missing[@]}"; do
    case "$pkg" in
        *:*) a=${pkg##*:}
             [[ "$known" == *" $a "* ]] || { foreign+=("$a"); known+="$a "; } ;;
    esac
done
add_arch=""
for a in "${foreign[@]}"; do add_arch+="dpkg --add-architecture $a && "; done

cmd="${add_arch}apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
    echo "install-deps: missing Debian packages: ${missing[*]}" >&2
    echo "install-deps: run as root:  $cmd" >&2
    exit 1
fi
echo "install-deps: installing ${missing[*]}"
for a in "${foreign[@]}"; do
    echo "install-deps: dpkg --add-architecture $a"
    dpkg --add-architecture "$a"
done
apt-get update -q
DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
pyenv_step
