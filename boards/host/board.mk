# Board "host": a Linux PC running the firmware image against host_sim.
# Build settings of a board are data; boards/<name>/board.h holds the memory budgets.
BOARD_DESCRIPTION := Linux host (x86-64), firmware cores as threads against host_sim
# Network preset compiled into the firmware image unless PRESET= is given.
BOARD_PRESET      := small
# Math back end of the AI core: eigen (C++ shim, fast) or ref (pure C, portable).
BOARD_LA_BACKEND  := eigen
# Code generation for this board's CPU (ARCH=, checked by the Makefile):
#   native    (default) the build machine's own CPU, every extension it has (AVX-512, AVX2,
#             NEON...): the fastest code, for binaries that run where they were built;
#   portable  a baseline every CPU of the family has: x86-64-v2 (SSE4.2, any x86-64 since
#             about 2009) or armv8-a, for binaries copied to other machines.
# Floating-point results depend on the code generated (vector width, FMA contraction), so
# the same seed is bit-identical per ARCH and machine, not across them.
BOARD_ARCHES := native portable
BOARD_HOST_MACHINE := $(shell uname -m)
ifeq ($(BOARD_HOST_MACHINE),aarch64)
BOARD_ARCH_FLAGS_native   := -mcpu=native
BOARD_ARCH_FLAGS_portable := -march=armv8-a
else
BOARD_ARCH_FLAGS_native   := -march=native
BOARD_ARCH_FLAGS_portable := -march=x86-64-v2
endif
