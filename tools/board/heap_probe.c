/* heap_probe.h on the two C libraries of the boards: glibc (mallinfo2) and newlib (mallinfo). */
#define _GNU_SOURCE 1
#include "heap_probe.h"

#include <malloc.h>

uint64_t heap_probe_in_use(void)
{
#if defined(__GLIBC__)
    return (uint64_t)mallinfo2().uordblks;
#else
    return (uint64_t)mallinfo().uordblks;
#endif
}
