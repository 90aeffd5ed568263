# Board "host": a Linux PC running the firmware image against host_sim.
# Build settings of a board are data; boards/<name>/board.h holds the memory budgets.
BOARD_DESCRIPTION := Linux host (x86-64), firmware cores as threads against host_sim
# Network preset compiled into the firmware image unless PRESET= is given.
BOARD_PRESET      := small
# Math back end of the AI core: eigen (C++ shim, fast) or ref (pure C, portable).
BOARD_LA_BACKEND  := eigen
# Code generation for this board's CPU. The host is the build machine itself.
BOARD_ARCH_FLAGS  := -march=native
