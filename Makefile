# fleetsim: the one entry point. `make help` lists the targets.
#
#   make [all]        libraries and programs of one configuration
#   make run          install missing packages (as root), build, run the fleet: 7 robots as 7
#                     host_sim processes over LCM (tools/fleet; FLEET_ARGS="..." adds options)
#   make run-inproc   the same job with all robots in one process (the reference)
#   make test         install missing packages (as root), build and run every cmocka test
#   make test-slurm   a one-node SLURM cluster on this machine (root; installs slurm-wlm and munge),
#                     tools/slurm/fleet.sbatch run on it (4 robots over ZeroMQ), its models
#                     compared with host_sim fleet --inproc's; daemons and scratch removed after
#   make test-asan    the tests under AddressSanitizer + UndefinedBehaviorSanitizer
#   make test-tsan    the threaded tests under ThreadSanitizer
#   make test-faults  the fleet as real processes under packet loss (tests/faults/: the fault
#                     injector, and the kernel's drops in a network namespace as root), a
#                     robot killed and resumed, a robot paused, a partition and its heal, and
#                     SCHEDULES=N (default 4000) schedules of the protocol's simulated network
#   make bench        benchmarks; one `BENCH <name> <value> <unit>` line per figure (with
#                     TORCH_PYTHON=<python with torch>, PyTorch's step and MC-50 beside ours)
#   make experiments  the paper's experiments and the KL question (hours, resumable):
#                     results/paper/REPORT.md; QUICK=1 the reduced form in minutes
#   make check-portable  the math compiled for x86-64-v2/v3/v4 and aarch64, all built with clang
#   make fuzz         the libFuzzer targets of tests/fuzz/ (datagrams into the fleet protocol,
#                     floor plans, tours, samples, checkpoints) built with clang, ASan and UBSan,
#                     FUZZ_SECONDS=N (default 60) each, after their regression inputs; fails on
#                     any crash, sanitizer report, leak or hang
#   make check-config the tree built for a board with other sizes; every file agrees on them
#   make cross        the firmware for the cross boards (Cortex-M4F, Cortex-M7, Cortex-A53)
#                     with their toolchains; fails when an image does not fit its board
#   make run-board    each board's image under QEMU; its losses must match the host build's
#   make profile-board  run-board, then results/board-<name>/profile.md: sections, stacks,
#                     instructions per training step and per inference, what the robot affords
#   make hil          [BOARD=mps2-an500] a fleet of 3 whose robot 0 is the board under QEMU, in the
#                     loop with host_sim hil (rpi3: its RT core alone)
#   make hil-rt       [BOARD=mps2-an500] the board's RT core alone in the loop with host_sim hil
#                     (UDP on rpi3; Ethernet, or HIL_LINK=serial UART 0, on the Cortex-M boards)
#   make clean
#
# Configuration (all optional):
#   BUILD=release|debug|asan|tsan|fuzz   BOARD=<dir in boards/>   PRESET=small|paper|mcu
#   (cross boards: BOARD=mps2-an386|mps2-an500|rpi3 with cross, run-board, profile-board)
#   LA_BACKEND=eigen|ref            ARCH=native|portable (release code for this CPU, or a
#   CC=gcc|clang, CXX=g++|clang++   baseline that runs on any CPU of its family)
#   FP_CONTRACT=fast|off            the firmware's a * b + c fused into FMAs where the CPU has
#                                   them (fast), or as written (off: a cross board's bits, what
#                                   a host robot beside a board in `make hil` is built with)
#   PRECISION=fp32|bf16             the training step's large GEMMs in fp32, or as bf16
#                                   products with fp32 sums (firmware/ai/README.md)
#                                   (bf16 is fast only on a CPU with AVX512_BF16: make warns)
#   V=1 (print whole commands)
# Objects and programs go to build/<BUILD>-<BOARD>-<PRESET>[-<LA_BACKEND>][-<ARCH>][-fpoff][-bf16][-clang]/;
# build/bin always points at the default build's programs (build/release-host-<board preset>/bin,
# what `make` and `make run` build); other configurations keep theirs in their own folder.
# `build/bin/host_sim --version` says which commit and configuration a program was built from.

.DEFAULT_GOAL := all
SHELL := /bin/bash
.SUFFIXES:
.DELETE_ON_ERROR:
.SECONDARY:

BUILD  ?= release
BOARD  ?= host

# Cross boards (boards/<name>/board.mk sets BOARD_KIND := cross) build through boards/cross.mk
# with their own toolchain: `make cross|run-board|profile-board [BOARD=<name>]`, every cross
# board when BOARD names none. The rest of this file builds for the host.
CROSS_BOARDS := $(sort $(patsubst boards/%/board.mk,%,$(shell grep -l '^BOARD_KIND *:= *cross' boards/*/board.mk)))
CROSS_GOALS  := cross run-board profile-board
ifneq ($(filter $(BOARD),$(CROSS_BOARDS)),)
CROSS_ONLY := $(BOARD)
override BOARD := host
ifneq ($(filter-out $(CROSS_GOALS) hil hil-rt,$(or $(MAKECMDGOALS),all)),)
$(error BOARD=$(CROSS_ONLY) is a cross board: its targets are $(CROSS_GOALS) hil hil-rt)
endif
endif

ifeq ($(wildcard boards/$(BOARD)/board.mk),)
$(error unknown BOARD '$(BOARD)': there is no boards/$(BOARD)/board.mk (boards: $(patsubst boards/%/board.mk,%,$(wildcard boards/*/board.mk))))
endif
include boards/$(BOARD)/board.mk
$(foreach v,BOARD_PRESET BOARD_LA_BACKEND BOARD_ARCHES,$(if $($(v)),,$(error boards/$(BOARD)/board.mk must set $(v))))

PRESET     ?= $(BOARD_PRESET)
LA_BACKEND ?= $(BOARD_LA_BACKEND)
PRESETS    := small paper mcu
ifeq ($(filter $(PRESET),$(PRESETS)),)
$(error unknown PRESET '$(PRESET)' (presets: $(PRESETS)))
endif
ifeq ($(filter $(LA_BACKEND),ref eigen),)
$(error unknown LA_BACKEND '$(LA_BACKEND)' (ref or eigen))
endif

# The default precision of the training step's large GEMMs (bnn_config_t.precision; a program
# may still choose per model, as bench_bnn does).
PRECISION ?= fp32
ifeq ($(filter $(PRECISION),fp32 bf16),)
$(error unknown PRECISION '$(PRECISION)' (fp32 or bf16))
endif

ARCH ?= $(firstword $(BOARD_ARCHES))
ifeq ($(filter $(ARCH),$(BOARD_ARCHES)),)
$(error unknown ARCH '$(ARCH)' (board $(BOARD): $(BOARD_ARCHES)))
endif
BOARD_ARCH_FLAGS := $(BOARD_ARCH_FLAGS_$(ARCH))

uc = $(shell echo '$(1)' | tr a-z A-Z)

CC      := gcc
CXX     := g++

# PRECISION=bf16 is only fast where the AVX512_BF16 kernel runs (firmware/ai/kernels/la_bf16.c
# picks it at run time on x86-64 with LA_BACKEND=eigen); anywhere else every bf16 product runs on
# the pure-C reference: the same bits, several times slower than fp32 (4.5x on an AVX2-only CPU).
# Said here, at build time, for the CPU this build runs on (-march=native's macros), and again by
# the programs at start (host_sim run and fleet, bench_bnn: host_sim/sim_kernels.h).
ifeq ($(PRECISION),bf16)
BF16_WHY := $(if $(filter-out eigen,$(LA_BACKEND)),LA_BACKEND=$(LA_BACKEND) builds only the reference kernels,$(if \
    $(filter x86_64,$(shell uname -m)),$(if $(shell $(CC) $(BOARD_ARCH_FLAGS_native) -dM -E -x c /dev/null 2>/dev/null \
    | grep __AVX512BF16__),,this machine's CPU has no AVX512_BF16 instructions ($(BOARD_ARCH_FLAGS_native) defines no \
    __AVX512BF16__)),there is no bf16 kernel for $(shell uname -m), only x86-64's AVX512_BF16))
ifneq ($(BF16_WHY),)
$(warning PRECISION=bf16: $(BF16_WHY), so the training step's bf16 products run on the pure-C reference kernel \
    (firmware/ai/kernels/la_bf16_ref.c): the same results, but several times slower than PRECISION=fp32 (4.5x on an \
    AVX2-only CPU). Build with PRECISION=fp32 unless you need a bf16 run's bits (firmware/ai/README.md))
endif
endif

BUILD_ROOT ?= build
# Anything that changes the generated code gets its own objects (no mixing on a switch): a
# math back end, an ARCH other than the board default, another compiler.
config_for = $(1)-$(BOARD)-$(2)$(if $(filter-out $(BOARD_LA_BACKEND),$(LA_BACKEND)),-$(LA_BACKEND))$(if $(filter-out $(firstword $(BOARD_ARCHES)),$(ARCH)),-$(ARCH))$(if $(filter off,$(FP_CONTRACT)),-fpoff)$(if $(filter bf16,$(PRECISION)),-bf16)$(if $(findstring clang,$(CC)),-clang)
CONFIG := $(call config_for,$(BUILD),$(PRESET))
O   := $(BUILD_ROOT)/$(CONFIG)
BIN := $(O)/bin
LIB := $(O)/lib
GEN := $(O)/gen

AR      := ar
PYTHON  ?= /usr/bin/python3
LCMGEN  := lcm-gen

ifeq ($(BUILD),release)
OPT := -O3 -g $(BOARD_ARCH_FLAGS)
else ifeq ($(BUILD),debug)
OPT := -O0 -g
else ifeq ($(BUILD),asan)
OPT := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
else ifeq ($(BUILD),tsan)
OPT := -O1 -g -fsanitize=thread
else ifeq ($(BUILD),fuzz)
# libFuzzer's coverage on every object, ASan and UBSan (`make fuzz`); clang only.
ifeq ($(findstring clang,$(CC)),)
$(error BUILD=fuzz needs clang: CC=clang CXX=clang++ (make fuzz sets them))
endif
OPT := -O1 -g -fno-omit-frame-pointer -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all
else
$(error unknown BUILD '$(BUILD)' (release, debug, asan, tsan or fuzz))
endif

WARN     := -Wall -Wextra -Werror
DEFS     := -DBNN_PRESET_$(call uc,$(PRESET))=1 -DLA_BACKEND_$(call uc,$(LA_BACKEND))=1 \
            $(if $(filter bf16,$(PRECISION)),-DBNN_PRECISION_DEFAULT_BF16=1)
CFLAGS   := -std=c11 $(WARN) $(OPT) $(DEFS) -MMD -MP
CXXFLAGS := -std=c++17 $(WARN) $(OPT) $(DEFS) -MMD -MP -fno-exceptions -fno-rtti

# The house rule (docs/architecture.md section 1): firmware/ sees only its own headers, hal/include and
# the board. The bottom half (hal/host, host_sim, tools, tests) also sees POSIX, the
# generated LCM types and host_sim.
# Every file, C or C++, of every layer sees the same build configuration (board settings and
# the defaults for what the board leaves out): firmware/common/fw_config.h, with -imacros.
# $(MSG_GEN) holds only what tools/lcmgen.py writes from firmware/msg (macros, <stdint.h>).
MSG_GEN  := $(O)/gen-fw
FW_INC   := -Ifirmware -Ihal/include -Iboards/$(BOARD) -I$(MSG_GEN) -imacros firmware/common/fw_config.h
# host_sim/ keeps one folder per family (floorplan, plangen, paths, world, fleet, maps) and its
# shared helpers at the top; the sim_ prefix keeps its header names unique across them.
SIM_DIRS := host_sim $(addprefix host_sim/,floorplan plangen paths world fleet maps)
HOST_INC := $(FW_INC) -Ihal/host $(addprefix -I,$(SIM_DIRS)) -I$(GEN) -D_POSIX_C_SOURCE=200809L
TEST_INC := $(HOST_INC) -Ihal/stdc -Itests/support -Itests

# No -lOSMesa: host_sim/maps/sim_render.c dlopens it at the first render (dlopen is in libc
# from glibc 2.34; an older glibc would need -ldl here).
SYS_LIBS := -lode -llcm -lzmq -lsodium -lcrypto -lpng -lm -lpthread
WRAP     := $(foreach f,malloc calloc realloc free aligned_alloc posix_memalign,-Wl,--wrap=$(f))

# ---- sources ----------------------------------------------------------------------------
FW_C      := $(sort $(shell find firmware -name '*.c'))
FW_CXX    := $(if $(filter eigen,$(LA_BACKEND)),$(sort $(shell find firmware -name '*.cpp')))
HAL_COMMON_C := $(sort $(wildcard hal/common/*.c))
HAL_C     := $(sort $(shell find hal/host -name '*.c'))
# The cross boards' back end on its Linux target, for its tests (tests/hal/test_stdc.c).
HAL_STDC_C := hal/stdc/hal_stdc.c hal/stdc/hal_stdc_posix.c hal/stdc/hal_stdc_posix_hil.c
SIM_C     := $(sort $(shell find host_sim -name '*.c' -not -path 'host_sim/app/*'))
APP_C     := $(sort $(wildcard host_sim/app/*.c))
MSG_LCM   := $(sort $(wildcard firmware/msg/*.lcm))
SUPPORT_C := $(sort $(wildcard tests/support/*.c))
# tests/faults/ (fleets under loss, slower, root for the kernel case) runs on its own:
# `make test-faults`, never in `make test`.
# tests/board/ holds the cross boards' own images (boards/cross.mk's `test`), never host tests.
TEST_C    := $(sort $(shell find tests -name 'test_*.c' -not -path 'tests/support/*' -not -path 'tests/faults/*' -not -path 'tests/fuzz/*' -not -path 'tests/board/*'))
FAULTS_TEST_C := $(sort $(wildcard tests/faults/test_*.c))
BENCH_C   := $(sort $(wildcard tools/bench/bench_*.c))
BENCH_SUPPORT_C := tools/bench/fma_probe.c

obj = $(patsubst %,$(O)/obj/%.o,$(1))

FW_OBJ      := $(call obj,$(FW_C) $(FW_CXX))
HAL_COMMON_OBJ := $(call obj,$(HAL_COMMON_C))
HAL_OBJ     := $(call obj,$(HAL_C))
HAL_STDC_OBJ := $(call obj,$(HAL_STDC_C))
SIM_OBJ     := $(call obj,$(SIM_C))
APP_OBJ     := $(call obj,$(APP_C))
SUPPORT_OBJ := $(call obj,$(SUPPORT_C))
TEST_BIN    := $(patsubst %.c,$(O)/%,$(TEST_C))
FAULTS_TEST_BIN := $(patsubst %.c,$(O)/%,$(FAULTS_TEST_C))
BENCH_BIN   := $(patsubst tools/bench/%.c,$(BIN)/%,$(BENCH_C))
BENCH_SUPPORT_OBJ := $(call obj,$(BENCH_SUPPORT_C))
PROGRAMS    := $(if $(APP_C),$(BIN)/host_sim $(BIN)/board_hil) $(BENCH_BIN)

LIBS := $(LIB)/libsim.a $(LIB)/libhal_host.a $(LIB)/libfirmware.a $(LIB)/libhal.a $(LIB)/libmsg.a
LINK_LIBS := -Wl,--start-group $(LIBS) -Wl,--end-group $(SYS_LIBS)

# ---- compile rules ----------------------------------------------------------------------
# One short line per step; V=1 prints the whole commands.
ifeq ($(V),1)
say =
else
say = @printf '  %-4s %s\n' '$(1)' '$(2)';
endif

# The firmware lets the compiler fuse a * b + c into one FMA where the CPU has it (ISO C mode
# turns that off by default): the element-wise passes of the trainer are polynomial chains,
# and an FMA is one rounding instead of two. Results stay deterministic per build and CPU.
# FP_CONTRACT=off builds it as the cross boards do (ISO C: nothing fused), so a host robot
# computes a board's bits: with fusing, robot 0's parameters after one round differed from the
# M7's in 25,575 of 33,601 floats (36 ulps the median), 4.4e-4 of its loss after 30 rounds.
# The packed GEMM kernels spell out every FMA (their kernels must agree bit for bit whatever the
# vector width), so the compiler may fuse nothing there.
FP_CONTRACT ?= fast
ifeq ($(filter $(FP_CONTRACT),fast off),)
$(error unknown FP_CONTRACT '$(FP_CONTRACT)' (fast or off))
endif
FW_FP := -ffp-contract=$(FP_CONTRACT)
$(O)/obj/firmware/ai/kernels/la_packed_%.c.o: FW_FP := -ffp-contract=off
# The bf16 kernels' roundings are their contract (la_bf16.h): none may be fused away either.
$(O)/obj/firmware/ai/kernels/la_bf16%.c.o: FW_FP := -ffp-contract=off
$(O)/obj/firmware/%.c.o: firmware/%.c
	@mkdir -p $(@D)
	$(call say,CC,$<)$(CC) $(CFLAGS) $(FW_FP) $(FW_INC) -c $< -o $@

$(O)/obj/firmware/%.cpp.o: firmware/%.cpp
	@mkdir -p $(@D)
	$(call say,CXX,$<)$(CXX) $(CXXFLAGS) $(FW_INC) -isystem /usr/include/eigen3 -c $< -o $@

# hal/common (the board registry every port shares) obeys the firmware's rules.
$(O)/obj/hal/common/%.c.o: hal/common/%.c
	@mkdir -p $(@D)
	$(call say,CC,$<)$(CC) $(CFLAGS) $(FW_INC) -c $< -o $@

# The bottom half may include generated LCM headers: they are built first (order-only).
$(O)/obj/hal/%.c.o: hal/%.c | $(GEN)/.stamp
	@mkdir -p $(@D)
	$(call say,CC,$<)$(CC) $(CFLAGS) $(HOST_INC) -c $< -o $@

$(O)/obj/host_sim/%.c.o: host_sim/%.c | $(GEN)/.stamp
	@mkdir -p $(@D)
	$(call say,CC,$<)$(CC) $(CFLAGS) $(HOST_INC) -c $< -o $@

$(O)/obj/tools/%.c.o: tools/%.c | $(GEN)/.stamp
	@mkdir -p $(@D)
	$(call say,CC,$<)$(CC) $(CFLAGS) $(HOST_INC) -c $< -o $@

$(O)/obj/tests/%.c.o: tests/%.c | $(GEN)/.stamp
	@mkdir -p $(@D)
	$(call say,CC,$<)$(CC) $(CFLAGS) $(TEST_INC) -c $< -o $@

# LCM message types: generated at build time, never committed. After `deps` (order-only): a
# parallel make on a fresh machine would otherwise run lcm-gen before it is installed.
$(GEN)/.stamp: $(MSG_LCM) | deps
	@rm -rf $(GEN)/lcm && mkdir -p $(GEN)/lcm
	$(call say,GEN,$(GEN)/lcm)$(if $(MSG_LCM),$(LCMGEN) -c --c-cpath $(GEN)/lcm --c-hpath $(GEN)/lcm --cinclude lcm $(MSG_LCM))
	@touch $@

# The messages' field layouts and fingerprints for the firmware and the bounds check
# (msg/msg_layout.h; tools/lcmgen.py says how to add a field): from the same .lcm files, at build
# time, never committed. Made before any object (the list at the end of this file); -MMD tracks
# who includes it after.
MSG_LAYOUT := $(MSG_GEN)/msg/msg_layout.h
$(MSG_LAYOUT): tools/lcmgen.py $(MSG_LCM) | deps
	$(call say,GEN,$@)$(PYTHON) tools/lcmgen.py -o $@ $(MSG_LCM)

# What `host_sim --version` says (host_sim/app/cmd_version.c): the commit (`git describe --always
# --dirty`; "unknown" outside a git tree) and the configuration. Checked at every make, rewritten
# only when it changed: a commit recompiles that one file and relinks host_sim, nothing else.
# (Only this tree's own .git: a copy unpacked inside another repository is not that one's commit.)
GIT_DESCRIBE := $(or $(if $(wildcard .git),$(shell git describe --always --dirty 2>/dev/null)),unknown)
BUILD_INFO := $(GEN)/build_info.h
.PHONY: FORCE
FORCE:
$(BUILD_INFO): FORCE
	@mkdir -p $(@D)
	@printf '%s\n' '/* Written by the Makefile at each make; rewritten only when it changes. */' \
	    '#define FLEETSIM_GIT_DESCRIBE "$(GIT_DESCRIBE)"' '#define FLEETSIM_BUILD_CONFIG "$(CONFIG)"' \
	    '#define FLEETSIM_BUILD_ARCH "$(ARCH)"' '#define FLEETSIM_BUILD_ARCH_FLAGS "$(strip $(BOARD_ARCH_FLAGS))"' >$@.tmp
	@if cmp -s $@.tmp $@; then rm -f $@.tmp; else mv -f $@.tmp $@; printf '  %-4s %s (%s)\n' GEN $@ '$(GIT_DESCRIBE)'; fi
$(O)/obj/host_sim/app/cmd_version.c.o: $(BUILD_INFO)

# Generated code is not ours to keep warning-free beyond what lcm-gen emits.
$(LIB)/libmsg.a: $(GEN)/.stamp
	@mkdir -p $(@D) $(O)/obj/gen
	@rm -f $@ $(O)/obj/gen/*.o
	@for c in $(GEN)/lcm/*.c; do [ -e "$$c" ] || continue; \
	    printf '  %-4s %s\n' CC "$$c"; \
	    $(CC) -std=c11 $(OPT) -Wall -Wno-unused-parameter -I$(GEN) -c "$$c" \
	        -o $(O)/obj/gen/$$(basename "$$c" .c).o || exit 1; done
	$(call say,AR,$@)$(AR) rcs $@ $$(ls $(O)/obj/gen/*.o 2>/dev/null)

# ---- libraries and programs -------------------------------------------------------------
$(LIB)/libfirmware.a: $(FW_OBJ)
$(LIB)/libhal.a: $(HAL_COMMON_OBJ)
# The layering check gates the two archives every board links (order-only: it is not archived):
# a host call in firmware/ (a debug print) stops the build before a program links it, not beside
# a link that runs in parallel with the check and leaves a program built from code that fails it.
LAYERING_OK := $(O)/layering.ok
$(LAYERING_OK): $(shell find firmware hal/common -name '*.[ch]' -o -name '*.cpp') tools/check-layering.sh
	@tools/check-layering.sh
	@mkdir -p $(@D) && touch $@
$(LIB)/libfirmware.a $(LIB)/libhal.a: | $(LAYERING_OK)
$(LIB)/libhal_host.a: $(HAL_OBJ)
$(LIB)/libhal_stdc.a: $(HAL_STDC_OBJ)
$(LIB)/libsim.a: $(SIM_OBJ)
$(LIB)/libtestsupport.a: $(SUPPORT_OBJ)
$(LIB)/libfirmware.a $(LIB)/libhal.a $(LIB)/libhal_host.a $(LIB)/libhal_stdc.a $(LIB)/libsim.a $(LIB)/libtestsupport.a:
	@mkdir -p $(@D)
	@rm -f $@
	$(call say,AR,$@)$(AR) rcs $@ $^

$(BIN)/host_sim: $(APP_OBJ) $(LIBS)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(CXX) $(OPT) $(APP_OBJ) $(LINK_LIBS) -o $@

# board_hil: the RT core on a Linux board in the loop with `host_sim hil` (docs/boards.md), on
# the cross boards' back end (hal/stdc), built for this host as a board's stand-in.
$(O)/obj/tools/board/%.c.o: HOST_INC += -Ihal/stdc
BOARD_HIL_OBJ := $(O)/obj/tools/board/board_hil.c.o $(O)/obj/tools/board/board_world.c.o
$(BIN)/board_hil: $(BOARD_HIL_OBJ) $(LIB)/libhal_stdc.a $(LIB)/libfirmware.a $(LIB)/libhal.a
	@mkdir -p $(@D)
	$(call say,LD,$@)$(CXX) $(OPT) $(BOARD_HIL_OBJ) -Wl,--start-group $(LIB)/libhal_stdc.a $(LIB)/libfirmware.a $(LIB)/libhal.a \
	    -Wl,--end-group -lm -o $@

# bench_bnn times the GEMMs inside the training step: its la_sgemm calls pass through a timer
# (--wrap), the firmware itself unchanged. It also runs every GEMM shape of the step on
# OpenBLAS in the same run, for comparison: only the benchmark links it, never the firmware.
BENCH_LDFLAGS_bnn := -Wl,--wrap=la_sgemm,--wrap=la_sgemm_ep,--wrap=la_bf16_gemm -lopenblas
$(BIN)/bench_%: $(O)/obj/tools/bench/bench_%.c.o $(BENCH_SUPPORT_OBJ) $(LIBS)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(CXX) $(OPT) $< $(BENCH_SUPPORT_OBJ) $(LINK_LIBS) $(BENCH_LDFLAGS_$*) -o $@

# One program per tests/<module>/test_<name>.c, linked with the allocation counter.
$(O)/tests/%: $(O)/obj/tests/%.c.o $(LIB)/libtestsupport.a $(LIB)/libhal_stdc.a $(LIBS)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(CXX) $(OPT) $< -Wl,--start-group $(LIB)/libtestsupport.a $(LIB)/libhal_stdc.a $(LIBS) -Wl,--end-group $(SYS_LIBS) -lcmocka $(WRAP) -o $@

# ---- targets ----------------------------------------------------------------------------
.PHONY: hil hil-rt host-sim print-host-sim experiments all layering deps run run-inproc test test-asan test-tsan test-faults test-slurm tests bench bench-one bench-pse-sim clean help check-portable check-config fuzz fuzz-build fuzz-seeds $(CROSS_GOALS)

# build/bin is the default build's, whatever was built last (a `make bench` builds the paper
# preset too): `build/bin/host_sim` never silently changes its network. Every other target
# names its own build folder ($(BIN)).
DEFAULT_CONFIG := release-host-$(if $(filter host,$(BOARD)),$(BOARD_PRESET),$(shell sed -n 's/^BOARD_PRESET *:= *//p' boards/host/board.mk))
all: deps layering $(LIBS) $(PROGRAMS)
ifeq ($(CONFIG),$(DEFAULT_CONFIG))
	@ln -sfn $(CONFIG)/bin $(BUILD_ROOT)/bin
else ifeq ($(BUILD),release)
	@echo "  programs in $(BIN) (build/bin stays the default build's: build/$(DEFAULT_CONFIG)/bin)"
endif

deps:
	@tools/install-deps.sh

# firmware/ may include only the C library, its own headers, hal/include and the board.
layering:
	@tools/check-layering.sh

# The fault tests are built with the others (so they keep compiling) but run only by test-faults.
tests: all $(TEST_BIN) $(FAULTS_TEST_BIN)

# The Python tools' tests run with the default build's tests: they start its programs
# (build/release-host-small/bin), so another build (LA_BACKEND=ref, CC=clang, a sanitizer)
# would only run them again on the same binaries.
TEST_PY := $(if $(filter $(DEFAULT_CONFIG),$(CONFIG)),$(sort $(wildcard tests/tools/test_*.py)))
test: tests
	@tools/run-tests.sh $(TEST_BIN) $(TEST_PY)

# With them, SCHEDULES schedules of the protocol's simulated network (tests/gp/test_pse_sim;
# `make test` runs 400).
SCHEDULES ?= 4000
PSE_SIM_BIN := $(filter %/tests/gp/test_pse_sim,$(TEST_BIN))
test-faults: all $(FAULTS_TEST_BIN) $(PSE_SIM_BIN)
	@FLEETSIM_PSE_SIM_SCHEDULES=$(SCHEDULES) tools/run-tests.sh $(FAULTS_TEST_BIN) $(PSE_SIM_BIN)

# The fleet under SLURM (tools/slurm/): not part of `make test` (root, daemons, packages).
test-slurm: all
	@tools/slurm/test-slurm.sh $(BIN)/host_sim

test-asan:
	@$(MAKE) --no-print-directory BUILD=asan test

# ThreadSanitizer runs the tests whose subject is concurrency.
TSAN_TESTS ?= tests/common tests/hal tests/image
test-tsan:
	@$(MAKE) --no-print-directory BUILD=tsan TEST_C="$$(find $(TSAN_TESTS) -name 'test_*.c' | sort)" test

# Benchmarks are release builds. Preset-specific ones (bench_bnn*) run for every preset
# named in BENCH_PRESETS, the rest once.
BENCH_PRESETS ?= small paper
bench:
	@tools/bench/cpu_info.sh
	@for p in $(BENCH_PRESETS); do \
	    $(MAKE) --no-print-directory BUILD=release PRESET=$$p bench-one \
	        BENCH_ONLY=$$( [ $$p = $(firstword $(BENCH_PRESETS)) ] && echo all || echo bnn ) || exit 1; \
	done

BENCH_ONLY ?= all
# The PyTorch comparison runs when this Python imports torch (not a dependency of the project).
TORCH_PYTHON ?= python3
bench-one: all
	@for b in $(BENCH_BIN); do \
	    case "$$(basename $$b)" in bench_bnn*) ;; *) [ "$(BENCH_ONLY)" = all ] || continue ;; esac; \
	    echo "# $$b (preset $(PRESET))"; $$b || exit 1; \
	done
	@if $(TORCH_PYTHON) -c 'import torch' 2>/dev/null; then \
	    echo "# tools/bench/torch_ref.py (preset $(PRESET): PyTorch's step and MC-50 beside ours, same run)"; \
	    $(TORCH_PYTHON) tools/bench/torch_ref.py --preset $(PRESET) --bench-bnn $(BIN)/bench_bnn --rounds 2 || exit 1; \
	else echo "# tools/bench/torch_ref.py skipped: $(TORCH_PYTHON) has no torch (TORCH_PYTHON=<python with torch>)"; fi
	@echo "# tools/bench/bench_fleet.py (preset $(PRESET): real processes over LCM udpm)"
	@tools/bench/bench_fleet.py --bin $(BIN)/host_sim --preset $(PRESET) $(if $(filter all,$(BENCH_ONLY)),--scaling)
	@if [ "$(BENCH_ONLY)" = all ]; then \
	    echo "# tools/bench/bench_faults.py (3 and 7 processes under 0-40 % kernel drops; needs root)"; \
	    tools/bench/bench_faults.py --bin $(BIN)/host_sim || exit 1; \
	    echo "# protocol simulation: schedules per minute"; \
	    $(MAKE) --no-print-directory bench-pse-sim; fi

# How many seeded schedules of the protocol simulation one core explores per minute.
bench-pse-sim: $(PSE_SIM_BIN)
	@t0=$$(date +%s.%N); FLEETSIM_PSE_SIM_SCHEDULES=2000 $(PSE_SIM_BIN) >/dev/null 2>&1 || exit 1; \
	    t1=$$(date +%s.%N); awk -v a=$$t0 -v b=$$t1 'BEGIN { printf "BENCH pse_sim_schedules_per_min %.0f schedules\n", 2000 * 60 / (b - a) }'

run: all
	@tools/fleet --bin $(BIN)/host_sim --name fleet $(FLEET_ARGS)

run-inproc: all
	@tools/run-fleet.sh $(BIN)

# The paper's experiments need the programs of both presets (release builds).
experiments:
	@$(MAKE) --no-print-directory BUILD=release PRESET=small all
	@$(MAKE) --no-print-directory BUILD=release PRESET=paper all
	@tools/experiments.py $(if $(QUICK),--quick) $(EXPERIMENTS_ARGS) \
	    --bin-small $(BUILD_ROOT)/$(call config_for,release,small)/bin/host_sim \
	    --bin-paper $(BUILD_ROOT)/$(call config_for,release,paper)/bin/host_sim

# The math compiled for every x86-64 level and aarch64 (GCC and clang), then the whole tree
# and its tests built and run with clang. Compile only for the other CPUs: this one need not
# have their instructions.
check-portable: deps
	@tools/install-deps.sh --portable
	@tools/check-portable.sh "$(DEFS) $(FW_INC)"
	@$(MAKE) --no-print-directory CC=clang CXX=clang++ test

# Fuzzing (tests/fuzz/README.md): one libFuzzer program per tests/fuzz/fuzz_<name>.c, in the
# build folder of BUILD=fuzz with clang (build/fuzz-<BOARD>-<PRESET>-clang/), so the other
# builds are untouched. tools/run-fuzz.sh runs each on a scratch copy of its corpus
# (tests/fuzz/corpus/<name>/ plus the binary seeds tests/fuzz/gen_seeds writes with the
# project's own encoders) for FUZZ_SECONDS, after its regression inputs
# (tests/fuzz/regressions/<name>/). `make fuzz-seeds` rewrites the checked-in binary seeds.
FUZZ_SECONDS ?= 60
FUZZ_C    := $(sort $(wildcard tests/fuzz/fuzz_*.c))
FUZZ_BIN  := $(patsubst %.c,$(O)/%,$(FUZZ_C))
FUZZ_GEN  := $(O)/tests/fuzz/gen_seeds
FUZZ_MAKE := $(MAKE) --no-print-directory BUILD=fuzz CC=clang CXX=clang++
FUZZ_O     = $(BUILD_ROOT)/$(call config_for,fuzz,$(PRESET))$(if $(findstring clang,$(CC)),,-clang)

$(O)/tests/fuzz/fuzz_%: $(O)/obj/tests/fuzz/fuzz_%.c.o $(LIBS)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(CXX) $(OPT) -fsanitize=fuzzer $< $(LINK_LIBS) -o $@

$(FUZZ_GEN): $(O)/obj/tests/fuzz/gen_seeds.c.o $(LIBS)
	@mkdir -p $(@D)
	$(call say,LD,$@)$(CXX) $(OPT) $< $(LINK_LIBS) -o $@

fuzz: deps
	@tools/install-deps.sh --fuzz
	@$(FUZZ_MAKE) fuzz-build
	@tools/run-fuzz.sh --seconds $(FUZZ_SECONDS) --bin $(FUZZ_O)/tests/fuzz

ifeq ($(BUILD),fuzz)
fuzz-build: $(FUZZ_BIN) $(FUZZ_GEN)
else
fuzz-build:
	@echo "fuzz-build is a step of make fuzz (BUILD=fuzz CC=clang CXX=clang++)" >&2; exit 1
endif

fuzz-seeds: deps
	@tools/install-deps.sh --fuzz
	@$(FUZZ_MAKE) fuzz-build
	@$(FUZZ_O)/tests/fuzz/gen_seeds tests/fuzz/corpus

# One build configuration per image: the tree built for boards/host_alt (every size changed)
# and tests/common/test_config.c run there, so a file that ignores the board shows up.
ALT_TESTS := $(addprefix $(BUILD_ROOT)/release-host_alt-$(PRESET)/tests/common/,test_config test_crc32)
check-config:
	@$(MAKE) --no-print-directory BOARD=host_alt all $(ALT_TESTS)
	@tools/run-tests.sh $(ALT_TESTS)

# The cross boards: `cross` builds libfirmware.a and the image (tools/board/board_train.c on
# hal/stdc) with the board's toolchain and fails when it does not fit; `run-board` runs it
# under QEMU beside the host build of the same program and compares their losses;
# `profile-board` writes results/board-<name>/profile.md and .json (and prints BENCH lines).
$(CROSS_GOALS):
	@tools/install-deps.sh --cross
	@for b in $(or $(CROSS_ONLY),$(CROSS_BOARDS)); do \
	    echo "# board $$b"; \
	    $(MAKE) --no-print-directory -f boards/cross.mk XBOARD=$$b \
	        $(patsubst cross,image,$(patsubst %-board,%,$@)) || exit 1; \
	done

# make hil BOARD=<board>: hardware in the loop with this host's host_sim (boards/cross.mk's `hil`
# and `hil-rt`; docs/boards.md). BOARD=mps2-an500 by default. `hil` on a Cortex-M board: a fleet
# whose robot 0 is the board (its whole image), the others host processes; on rpi3 and with
# `hil-rt`: the board's RT core alone.
hil hil-rt: $(BIN)/host_sim
	@tools/install-deps.sh --cross
	@$(MAKE) --no-print-directory -f boards/cross.mk XBOARD=$(or $(CROSS_ONLY),mps2-an500) $@ \
	    HOST_SIM=$(abspath $(BIN)/host_sim)

# host_sim alone, and its path (boards/cross.mk builds the host robots of a HIL fleet with the
# board's preset and math: make BOARD=host PRESET=.. LA_BACKEND=.. host-sim).
host-sim: $(BIN)/host_sim
print-host-sim:
	@echo $(abspath $(BIN)/host_sim)

clean:
	rm -rf build

help:
	@sed -n '1,/^$$/p' Makefile | sed 's/^# \{0,1\}//'

# Any object may include msg/msg_layout.h (through gp_wire.h): it is made before they compile.
# On the objects themselves, not in their pattern rules or a stamp: with .SECONDARY a missing
# header behind an up-to-date stamp would not be remade.
$(call obj,$(FW_C) $(FW_CXX) $(HAL_COMMON_C) $(HAL_C) $(HAL_STDC_C) $(SIM_C) $(APP_C) $(SUPPORT_C) $(TEST_C) \
    $(FAULTS_TEST_C) $(BENCH_C) $(BENCH_SUPPORT_C) $(FUZZ_C) tests/fuzz/gen_seeds.c): | $(MSG_LAYOUT)

-include $(shell find $(O)/obj -name '*.d' 2>/dev/null)
