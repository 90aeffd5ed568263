/* Bytes the C library's heap has handed out and not taken back, for the board images' "no
 * allocation after init" figure. The firmware allocates nothing; what the heap holds is the C
 * library's own (stdio buffers). */
#ifndef BOARD_HEAP_PROBE_H
#define BOARD_HEAP_PROBE_H

#include <stdint.h>

uint64_t heap_probe_in_use(void);

#endif /* BOARD_HEAP_PROBE_H */
