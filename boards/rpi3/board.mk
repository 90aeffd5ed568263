# Board "rpi3": Cortex-A53 Linux (board.h says which computer it stands for).
BOARD_KIND        := cross
BOARD_DESCRIPTION := Cortex-A53 Linux, Raspberry Pi 3 class (1.2 GHz, 1 GB), QEMU user mode
BOARD_PRESET      := small
BOARD_LA_BACKEND  := eigen
# Toolchain and code generation (Debian: g++-aarch64-linux-gnu).
BOARD_CROSS       := aarch64-linux-gnu-
BOARD_CPU_FLAGS   := -mcpu=cortex-a53
# HAL back end: the stdc board on Linux; a static executable.
BOARD_HAL_TARGET  := posix
BOARD_LINK        := linux
# How the image runs: QEMU user mode (no instruction counter here: see docs/boards.md).
BOARD_QEMU        := qemu-aarch64 -cpu cortex-a53
