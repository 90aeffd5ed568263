/* Allocation counter for tests: proves that a code path allocates nothing.
 *
 * Every test program is linked with -Wl,--wrap for malloc, calloc, realloc, free,
 * aligned_alloc and posix_memalign, so each call made from the project's objects (firmware,
 * hal, host_sim, the Eigen shim, the test itself) passes through a counter before reaching
 * the real allocator. Calls made inside shared libraries (libc, ODE, LCM) are not seen;
 * that is the point: the rule is about our code. The wrap works under AddressSanitizer too,
 * because __real_malloc is the sanitizer's malloc.
 *
 * Thread-safe (atomic counters). Typical use:
 *     alloc_count_reset();
 *     steady_state_step();
 *     assert_int_equal(alloc_count_allocations(), 0);
 */
#ifndef TESTS_SUPPORT_ALLOC_COUNT_H
#define TESTS_SUPPORT_ALLOC_COUNT_H

#include <stdint.h>

/* Zero both counters. */
void alloc_count_reset(void);

/* malloc, calloc, realloc, aligned_alloc and posix_memalign calls since the last reset. */
uint64_t alloc_count_allocations(void);

/* free calls (with a non-NULL pointer) since the last reset. */
uint64_t alloc_count_frees(void);

#endif /* TESTS_SUPPORT_ALLOC_COUNT_H */
