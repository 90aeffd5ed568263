# Board "host_alt": the host board with other buffer sizes. It exists to prove that every file
# takes its sizes from the board (`make check-config` builds the tree for it and runs
# tests/common/test_config.c); use `host` for real work.
include boards/host/board.mk
BOARD_DESCRIPTION := Linux host with other buffer sizes (configuration test board)
