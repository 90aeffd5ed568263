# Board "mps2-an386": Cortex-M4F under QEMU (board.h says which part it stands for).
BOARD_KIND        := cross
BOARD_DESCRIPTION := Cortex-M4F, STM32F429-class (2 MB flash, 256 KB SRAM, 8 MB SDRAM), QEMU mps2-an386
BOARD_PRESET      := mcu
BOARD_LA_BACKEND  := ref
# Toolchain and code generation (Debian: gcc-arm-none-eabi, libnewlib-arm-none-eabi).
BOARD_CROSS       := arm-none-eabi-
BOARD_CPU_FLAGS   := -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16
# HAL back end: the stdc board on the bare-metal Cortex-M target, semihosting C library.
BOARD_HAL_TARGET  := cortex_m
BOARD_LINK        := cortex_m
# How the image runs: QEMU with semihosting; -icount shift=0 makes one instruction 1 ns of
# virtual time (instruction counts). The program's arguments follow as arg=... pairs.
BOARD_QEMU        := qemu-system-arm -M mps2-an386 -nographic -icount shift=0,sleep=off
