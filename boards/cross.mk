# Cross builds of one board (boards/<name>/board.mk with BOARD_KIND := cross). The top-level
# Makefile runs it once per board: `make cross|run-board|profile-board [BOARD=<name>]`.
#
#   make -f boards/cross.mk XBOARD=<name> image     libfirmware.a for the board, and the image
#   make -f boards/cross.mk XBOARD=<name> run       image under emulation and the host build of
#                                                   the same program; their losses must agree
#   make -f boards/cross.mk XBOARD=<name> profile   run, then profile.md / profile.json
#   make -f boards/cross.mk XBOARD=<name> test      a Linux board only: tests/ai/test_la_packed.c
#                                                   built for the board, run under its QEMU
#                                                   (`run` and `profile` run it first)
#
#   LA_EXTRA_DEFS=-D...   more -D flags for every object of the image, its host reference and
#                         the cross test, for measurements: LA_EXTRA_DEFS=-DLA_PACKED_NONE builds
#                         without the packed GEMM kernels (Eigen does every product). Builds go
#                         to build/cross-<board>-<preset>-<defs> and results to
#                         results/board-<board>-<defs> (e.g. ...-rpi3-small-LA_PACKED_NONE), so
#                         objects of other flags never mix and the board's profile stays.
#
# The image is tools/board/board_train.c on the stdc HAL back end (hal/stdc) for the board's
# target, linked with the whole of libfirmware.a: every module of firmware/ is compiled with
# the board's toolchain and flags, and every module's static state is placed in the board's
# memories (boards/common/cortex_m.ld on bare metal), so a robot that does not fit the board
# does not link.
SHELL := /bin/bash
.SUFFIXES:
.DELETE_ON_ERROR:
.SECONDARY:

ifeq ($(XBOARD),)
$(error XBOARD= is missing (a directory of boards/ whose board.mk sets BOARD_KIND := cross))
endif
include boards/$(XBOARD)/board.mk
ifneq ($(BOARD_KIND),cross)
$(error boards/$(XBOARD) is not a cross board (its board.mk does not set BOARD_KIND := cross))
endif

comma    := ,
empty    :=
space    := $(empty) $(empty)

PRESET     ?= $(BOARD_PRESET)
LA_BACKEND := $(BOARD_LA_BACKEND)
BUILD_ROOT ?= build
RESULTS    ?= results
LA_EXTRA_DEFS ?=
ifneq ($(filter-out -D%,$(LA_EXTRA_DEFS)),)
$(error LA_EXTRA_DEFS takes -D flags only (got '$(LA_EXTRA_DEFS)'))
endif
# The directories' suffix: the macros without -D, '=' as '_' (-DA -DB=2: A-B_2).
XTAG := $(subst $(space),-,$(strip $(subst =,_,$(patsubst -D%,%,$(LA_EXTRA_DEFS)))))
X   := $(BUILD_ROOT)/cross-$(XBOARD)-$(PRESET)$(if $(XTAG),-$(XTAG))
R   := $(RESULTS)/board-$(XBOARD)$(if $(XTAG),-$(XTAG))
uc   = $(shell echo '$(1)' | tr a-z A-Z)

XCC  := $(BOARD_CROSS)gcc
XCXX := $(BOARD_CROSS)g++
DEFS := -DBNN_PRESET_$(call uc,$(PRESET))=1 -DLA_BACKEND_$(call uc,$(LA_BACKEND))=1 $(LA_EXTRA_DEFS)
WARN := -Wall -Wextra -Werror
# -fstack-usage: one .su file per object, the frame of every function; -fcallgraph-info=su one
# .ci file with the calls and frames, from which the profile sums the deepest chain per core.
XFLAGS   := $(WARN) -O2 -g $(BOARD_CPU_FLAGS) -ffunction-sections -fdata-sections -fstack-usage -fcallgraph-info=su $(DEFS) -MMD -MP
XCFLAGS  := -std=c11 $(XFLAGS)
XCXXFLAGS := -std=c++17 $(XFLAGS) -fno-exceptions -fno-rtti
# The messages' field layouts (tools/lcmgen.py from firmware/msg/*.lcm), as in the host build.
MSG_GEN  := $(X)/gen-fw
PYTHON   ?= /usr/bin/python3
FW_INC   := -Ifirmware -Ihal/include -Iboards/$(XBOARD) -I$(MSG_GEN) -imacros firmware/common/fw_config.h
IMG_INC  := $(FW_INC) -Ihal/stdc -Itools/board

FW_C    := $(sort $(shell find firmware -name '*.c'))
FW_CXX  := $(if $(filter eigen,$(LA_BACKEND)),$(sort $(shell find firmware -name '*.cpp')))
# The program and its HAL, the same for the image and the host reference but for the target file.
PROG_HAL_C := $(sort $(wildcard hal/common/*.c)) hal/stdc/hal_stdc.c
PROG_C     := tools/board/board_train.c tools/board/heap_probe.c
# The target's files of hal/stdc (start-up, time base, cores); its link ports only in board_hil.
TARGET_ALL_C := $(sort $(wildcard hal/stdc/hal_stdc_$(BOARD_HAL_TARGET)*.c))
TARGET_C := $(filter-out %_hil.c,$(TARGET_ALL_C))
IMG_C   := $(PROG_HAL_C) $(TARGET_C) $(PROG_C)
FW_OBJ  := $(patsubst %,$(X)/obj/%.o,$(FW_C) $(FW_CXX))
IMG_OBJ := $(patsubst %,$(X)/obj/%.o,$(IMG_C))
IMAGE   := $(X)/fleetsim.elf

# The host build of the same program (same board.h, preset and math), the reference.
HOST_X   := $(X)/host
HOST_C   := $(FW_C) $(PROG_HAL_C) hal/stdc/hal_stdc_posix.c $(PROG_C)
HOST_OBJ := $(patsubst %,$(HOST_X)/obj/%.o,$(HOST_C) $(FW_CXX))
HOST_BIN := $(HOST_X)/board_train

# No --gc-sections: the image carries all of firmware/ (the code of the three cores, not only
# what board_train calls), so its sections are the robot's.
ifeq ($(BOARD_LINK),cortex_m)
# newlib with semihosting (librdimon); our own start-up (hal_stdc_cortex_m.c), no crt0.
LINK_FLAGS := -nostartfiles -T $(X)/board.ld -Wl,-Map=$(X)/fleetsim.map
LINK_LIBS  := -Wl,--start-group -lc -lrdimon -lm -lgcc -Wl,--end-group
else
# A Linux board: one static executable (no shared libraries to install on the board).
LINK_FLAGS := -static -Wl,-Map=$(X)/fleetsim.map
LINK_LIBS  := -lm
endif

ifeq ($(V),1)
say =
else
say = @printf '  %-4s %s\n' '$(1)' '$(2)';
endif

.PHONY: image run profile test hil hil-rt robot
image: $(IMAGE)

# The flags live here and in the board's board.mk: a change there rebuilds.
FLAG_FILES := boards/cross.mk boards/$(XBOARD)/board.mk

$(X)/obj/%.c.o: %.c $(FLAG_FILES)
	@mkdir -p $(@D)
	$(call say,CC,$< [$(XBOARD)])$(XCC) $(XCFLAGS) $(IMG_INC) -c $< -o $@

$(X)/obj/%.cpp.o: %.cpp $(FLAG_FILES)
	@mkdir -p $(@D)
	$(call say,CXX,$< [$(XBOARD)])$(XCXX) $(XCXXFLAGS) $(FW_INC) -isystem /usr/include/eigen3 -c $< -o $@

$(MSG_GEN)/msg/msg_layout.h: tools/lcmgen.py $(wildcard firmware/msg/*.lcm)
	$(call say,GEN,$@)$(PYTHON) tools/lcmgen.py -o $@ $(wildcard firmware/msg/*.lcm)
$(FW_OBJ) $(IMG_OBJ) $(HOST_OBJ): | $(MSG_GEN)/msg/msg_layout.h

$(X)/lib/libfirmware.a: $(FW_OBJ)
	@mkdir -p $(@D)
	@rm -f $@
	$(call say,AR,$@)$(BOARD_CROSS)ar rcs $@ $^

$(X)/board.ld: boards/common/cortex_m.ld boards/$(XBOARD)/board.h
	@mkdir -p $(@D)
	$(call say,LDS,$@)$(XCC) -E -P -x c -imacros boards/$(XBOARD)/board.h $< -o $@

# The whole archive: every module, so every module's state is placed (and checked).
$(IMAGE): boards/cross.mk $(IMG_OBJ) $(X)/lib/libfirmware.a $(if $(filter cortex_m,$(BOARD_LINK)),$(X)/board.ld)
	$(call say,LD,$@)$(if $(FW_CXX),$(XCXX),$(XCC)) $(BOARD_CPU_FLAGS) $(LINK_FLAGS) $(IMG_OBJ) \
	    -Wl,--whole-archive $(X)/lib/libfirmware.a -Wl,--no-whole-archive $(LINK_LIBS) -o $@ 2> $(X)/link.log \
	    || { cat $(X)/link.log >&2; if grep -q 'overflowed by' $(X)/link.log; then \
	        echo "make cross: the image of $(XBOARD) does not fit the board: $$(grep -oE "section \`[^']*' will not fit in region \`[A-Z]*'|region \`[A-Z]*' overflowed by [0-9]* bytes" $(X)/link.log | sort -u | paste -sd ';' | sed 's/;/; /g')" >&2; fi; exit 1; }
	@$(BOARD_CROSS)size $@ | sed 's/^/  /'

$(HOST_X)/obj/%.c.o: %.c $(FLAG_FILES)
	@mkdir -p $(@D)
	$(call say,CC,$< [host reference])gcc $(WARN) -std=c11 -O2 -g $(DEFS) -MMD -MP $(IMG_INC) -c $< -o $@

$(HOST_X)/obj/%.cpp.o: %.cpp $(FLAG_FILES)
	@mkdir -p $(@D)
	$(call say,CXX,$< [host reference])g++ $(WARN) -std=c++17 -O2 -g $(DEFS) -fno-exceptions -fno-rtti $(FW_INC) -isystem /usr/include/eigen3 -c $< -o $@

$(HOST_BIN): $(HOST_OBJ)
	$(call say,LD,$@)g++ $^ -lm -o $@

# The run: the image on the emulated board and the host reference, same arguments; then the
# comparison (exit 1 when the losses disagree). Bare metal takes its arguments through
# semihosting (arg=...), a Linux image on its command line.
RUN_ARGS ?=
SAMPLES  := tools/board/train_samples.bin
PROG_ARGS := --dir $(abspath $(dir $(SAMPLES))) $(RUN_ARGS)
# A Linux board's instructions: QEMU's user mode has no -icount; the plugin counts them and
# logs the count at the program's marks (tools/board/qemu_insn.c).
INSN_PLUGIN := $(X)/qemu_insn.so
ifeq ($(BOARD_LINK),cortex_m)
RUN_CMD := $(BOARD_QEMU) -semihosting-config enable=on,target=native,arg=board_train$(subst $(space),,$(foreach a,$(PROG_ARGS),$(comma)arg=$(a))) -kernel $(IMAGE)
else
RUN_CMD := $(BOARD_QEMU) -plugin $(INSN_PLUGIN) -d plugin -D $(R)/insn.log $(IMAGE) $(PROG_ARGS)
RUN_DEPS := $(INSN_PLUGIN)
endif

$(INSN_PLUGIN): tools/board/qemu_insn.c
	@mkdir -p $(@D)
	$(call say,CC,$< [QEMU plugin])gcc -std=c11 $(WARN) -O2 -shared -fPIC $< -o $@
# The suite's cross pass, on a Linux board (BOARD_LINK := linux: rpi3): the packed-GEMM test
# (tests/ai/test_la_packed.c, cmocka) built with the board's toolchain and flags against the
# board's libfirmware.a and the allocation counter (tests/support/alloc_count.c, malloc & co.
# wrapped as in the host suite), then run under the board's QEMU: the kernels the target carries
# (NEON on aarch64) must pass, the others are skipped with the reason. Its cmocka output is
# printed and kept in $(R)/test_la_packed.txt; a failure fails the target. cmocka comes from
# Debian's multiarch package (libcmocka-dev:arm64, tools/install-deps.sh --cross): static when
# the package has libcmocka.a, otherwise (bookworm) shared, and QEMU finds the board's dynamic
# loader and C library with -L /usr/<triple>.
ifeq ($(BOARD_LINK),linux)
XTRIPLE    := $(patsubst %-,%,$(BOARD_CROSS))
XTEST_C    := tests/ai/test_la_packed.c tests/support/alloc_count.c
XTEST_OBJ  := $(patsubst %,$(X)/test/obj/%.o,$(XTEST_C))
XTEST      := $(X)/test/test_la_packed
XTEST_WRAP := $(foreach f,malloc calloc realloc free aligned_alloc posix_memalign,-Wl,--wrap=$(f))
XCMOCKA_A  := $(wildcard /usr/lib/$(XTRIPLE)/libcmocka.a)
XTEST_LIBS := $(if $(XCMOCKA_A),-static $(XCMOCKA_A),-lcmocka)
XTEST_CMD  := $(BOARD_QEMU) $(if $(XCMOCKA_A),,-L /usr/$(XTRIPLE)) $(XTEST)
TEST_DEPS  := test

$(X)/test/obj/%.c.o: %.c $(FLAG_FILES)
	@mkdir -p $(@D)
	$(call say,CC,$< [$(XBOARD) test])$(XCC) $(XCFLAGS) $(FW_INC) -Itests/support -Itests -c $< -o $@

$(XTEST): $(XTEST_OBJ) $(X)/lib/libfirmware.a
	@test -e /usr/lib/$(XTRIPLE)/libcmocka.so -o -n "$(XCMOCKA_A)" || { echo "make: no cmocka for $(XTRIPLE) (libcmocka-dev:$(subst aarch64,arm64,$(firstword $(subst -, ,$(XTRIPLE))))): run tools/install-deps.sh --cross as root" >&2; exit 1; }
	$(call say,LD,$@)$(XCXX) $(BOARD_CPU_FLAGS) $(XTEST_OBJ) $(X)/lib/libfirmware.a $(XTEST_LIBS) $(XTEST_WRAP) -lm -o $@

test: $(XTEST)
	@mkdir -p $(R)
	@echo "  TEST $(XBOARD): $(XTEST_CMD)"
	@set -o pipefail; timeout $(or $(TEST_TIMEOUT),900) $(XTEST_CMD) 2>&1 | tee $(R)/test_la_packed.txt | sed 's/^/  /' \
	    || { s=$$?; echo "make: tests/ai/test_la_packed.c failed on $(XBOARD) (exit $$s)" >&2; exit 1; }
else
# On a Cortex-M board: the scheduler's contract (tests/board/test_cm_cores.c, an image of its
# own on the board's HAL: cmocka's lines printed by hand, newlib has no cmocka), run under the
# board's QEMU; its output is kept in $(R)/test_cm_cores.txt and a failure fails the target.
XTEST_C   := tests/board/test_cm_cores.c $(PROG_HAL_C) $(TARGET_C)
XTEST_OBJ := $(patsubst %,$(X)/test/obj/%.o,$(XTEST_C))
XTEST     := $(X)/test/test_cm_cores.elf
XTEST_CMD := $(BOARD_QEMU) -semihosting-config enable=on,target=native,arg=test_cm_cores -kernel $(XTEST)
TEST_DEPS := test

$(X)/test/obj/%.c.o: %.c $(FLAG_FILES)
	@mkdir -p $(@D)
	$(call say,CC,$< [$(XBOARD) test])$(XCC) $(XCFLAGS) $(IMG_INC) -c $< -o $@
$(XTEST_OBJ): | $(MSG_GEN)/msg/msg_layout.h

$(XTEST): $(XTEST_OBJ) $(X)/lib/libfirmware.a $(X)/board.ld
	$(call say,LD,$@)$(XCC) $(BOARD_CPU_FLAGS) -nostartfiles -T $(X)/board.ld $(XTEST_OBJ) $(X)/lib/libfirmware.a \
	    $(LINK_LIBS) -o $@

test: $(XTEST)
	@mkdir -p $(R)
	@echo "  TEST $(XBOARD): $(XTEST_CMD)"
	@set -o pipefail; timeout $(or $(TEST_TIMEOUT),300) $(XTEST_CMD) 2>&1 | tee $(R)/test_cm_cores.txt | sed 's/^/  /' \
	    || { s=$$?; echo "make: tests/board/test_cm_cores.c failed on $(XBOARD) (exit $$s)" >&2; exit 1; }
endif

run: $(TEST_DEPS) $(IMAGE) $(HOST_BIN) $(RUN_DEPS)
	@mkdir -p $(R)
	@echo "  RUN  $(XBOARD): $(RUN_CMD)"
	@timeout $(or $(RUN_TIMEOUT),900) $(RUN_CMD) > $(R)/run.txt \
	    || { s=$$?; cat $(R)/run.txt; echo "make run-board: the image of $(XBOARD) failed (exit $$s)" >&2; exit 1; }
	@$(HOST_BIN) $(PROG_ARGS) > $(R)/host.txt
	@tools/board/board_check.py $(R)/run.txt $(R)/host.txt

# The profile of the run: the image's memory by module and the instructions per step
# (profile.md, profile.json). Lost once in a refactor, after which `make profile-board` printed
# "Nothing to be done" and ran no board for a week: tests/tools/test_board.py now checks that
# every goal the top Makefile hands this file has a rule here.
profile: run
	@tools/board/board_profile.py --board $(XBOARD) --preset $(PRESET) --board-h boards/$(XBOARD)/board.h \
	    --elf $(IMAGE) --map $(X)/fleetsim.map --obj $(X)/obj --cross $(BOARD_CROSS) \
	    --run $(R)/run.txt $(if $(RUN_DEPS),--insn-log $(R)/insn.log) --out $(R)

# Hardware in the loop (docs/boards.md): the firmware's RT core (tools/board/board_hil.c, built
# for the board with its link ports) under the board's QEMU, in the loop with `host_sim hil` of
# the host build (HOST_SIM=, the top Makefile passes it) for HIL_SECONDS of the board's time;
# both ends' output in $(R)/hil/. HIL_LINK: a Linux board speaks UDP (udp); a Cortex-M board
# its LAN9118 Ethernet (ether, the default: QEMU's -nic socket carries its frames to the world
# in UDP datagrams) or its UART 0 (serial: QEMU's -serial tcp: carries the bytes), its console
# staying on semihosting. @PORT@ is the world's port, filled in by run_hil.sh.
HIL_SECONDS ?= 20
HIL_PLAN    ?= host_sim/plans/apartment.svg
HIL_TOUR    ?= host_sim/plans/apartment/robot_0.csv
HIL_C   := tools/board/board_hil.c tools/board/board_world.c $(PROG_HAL_C) $(TARGET_ALL_C)
HIL_OBJ := $(patsubst %,$(X)/obj/%.o,$(HIL_C))
$(HIL_OBJ): | $(MSG_GEN)/msg/msg_layout.h
ifeq ($(BOARD_LINK),linux)
HIL_LINK ?= udp
HIL_LINKS := udp
HIL_BIN := $(X)/board_hil
$(HIL_BIN): $(HIL_OBJ) $(X)/lib/libfirmware.a
	$(call say,LD,$@)$(if $(FW_CXX),$(XCXX),$(XCC)) $(BOARD_CPU_FLAGS) -static $(HIL_OBJ) $(X)/lib/libfirmware.a -lm -o $@
HIL_RUN := tools/board/run_hil.sh --link udp $(HOST_SIM) $(HIL_PLAN) $(HIL_TOUR) $(HIL_SECONDS) $(R)/hil \
	$(BOARD_QEMU) $(HIL_BIN)
else
HIL_LINK ?= ether
HIL_LINKS := ether serial
HIL_BIN := $(X)/board_hil.elf
$(HIL_BIN): $(HIL_OBJ) $(X)/lib/libfirmware.a $(X)/board.ld
	$(call say,LD,$@)$(if $(FW_CXX),$(XCXX),$(XCC)) $(BOARD_CPU_FLAGS) $(LINK_FLAGS:fleetsim.map=board_hil.map) $(HIL_OBJ) \
	    $(X)/lib/libfirmware.a $(LINK_LIBS) -o $@
HIL_PORT := $(if $(filter ether,$(HIL_LINK)),eth0,uart0)
HIL_WIRE := $(if $(filter ether,$(HIL_LINK)),-nic socket$(comma)udp=127.0.0.1:@PORT@$(comma)localaddr=127.0.0.1:0,-serial tcp:127.0.0.1:@PORT@)
HIL_ARGS := board_hil --connect $(HIL_PORT) --tour $(HIL_TOUR) --time $(HIL_SECONDS)
# The whole robot (tools/board/board_robot.c: fw_robot's three cores on the board's scheduler).
ROBOT_C   := tools/board/board_robot.c tools/board/board_world.c $(PROG_HAL_C) $(TARGET_ALL_C)
ROBOT_OBJ := $(patsubst %,$(X)/obj/%.o,$(ROBOT_C))
ROBOT_BIN := $(X)/board_robot.elf
$(ROBOT_OBJ): | $(MSG_GEN)/msg/msg_layout.h
$(ROBOT_BIN): $(ROBOT_OBJ) $(X)/lib/libfirmware.a $(X)/board.ld
	$(call say,LD,$@)$(if $(FW_CXX),$(XCXX),$(XCC)) $(BOARD_CPU_FLAGS) $(LINK_FLAGS:fleetsim.map=board_robot.map) \
	    $(ROBOT_OBJ) $(X)/lib/libfirmware.a $(LINK_LIBS) -o $@
robot: $(ROBOT_BIN)
HIL_RUN  := tools/board/run_hil.sh --link $(HIL_LINK) $(HOST_SIM) $(HIL_PLAN) $(HIL_TOUR) $(HIL_SECONDS) $(R)/hil \
	$(BOARD_QEMU) -monitor none $(HIL_WIRE) \
	-semihosting-config enable=on,target=native$(subst $(space),,$(foreach a,$(HIL_ARGS),$(comma)arg=$(a))) -kernel $(HIL_BIN)
endif

hil-rt: $(HIL_BIN)
	@test -n "$(filter $(HIL_LINK),$(HIL_LINKS))" || { echo "make hil-rt: HIL_LINK=$(HIL_LINK): $(XBOARD) speaks $(HIL_LINKS)" >&2; exit 2; }
	@test -x "$(HOST_SIM)" || { echo "make hil-rt: HOST_SIM='$(HOST_SIM)' is not host_sim (run it from the top: make hil-rt BOARD=$(XBOARD))" >&2; exit 2; }
	@$(HIL_RUN)

ifeq ($(BOARD_LINK),linux)
hil: hil-rt
else
# The whole robot in a fleet (tools/board/hil_fleet.py): robot 0 is board_robot.elf under the
# board's QEMU (sleep=on: an idle board waits in real time, as its peers do), the others and the
# reference fleet are host_sim processes built with the board's preset and math (and nothing
# fused: FP_CONTRACT=off), so robot 0's
# final validation loss on the board and on the host must agree (HIL_RTOL).
HIL_ROBOTS      ?= 3
HIL_ROUNDS      ?= 30
HIL_POST_ROUNDS ?= 3
HIL_RTOL        ?= 1e-4
HIL_QEMU := $(subst -icount shift=0$(comma)sleep=off,,$(BOARD_QEMU))
# The host robots: the board's preset and math, nothing fused (its compiler fuses nothing).
HIL_HOST_CONFIG := BOARD=host PRESET=$(BOARD_PRESET) LA_BACKEND=$(BOARD_LA_BACKEND) FP_CONTRACT=off
hil: $(ROBOT_BIN)
	@$(MAKE) --no-print-directory -f Makefile $(HIL_HOST_CONFIG) host-sim
	@tools/board/hil_fleet.py --board $(XBOARD) --qemu "$(HIL_QEMU)" --elf $(ROBOT_BIN) \
	    --host-sim "$$($(MAKE) -s --no-print-directory -f Makefile $(HIL_HOST_CONFIG) print-host-sim)" \
	    --robots $(HIL_ROBOTS) --rounds $(HIL_ROUNDS) --post-rounds $(HIL_POST_ROUNDS) --rtol $(HIL_RTOL) \
	    --out $(R)/hil-fleet
endif

# The compilers' dependency files (-MMD -MP): a header's change rebuilds what includes it.
-include $(shell find $(X) -name '*.d' 2>/dev/null)
