#include "alloc_count.h"

#include <stdatomic.h>
#include <stddef.h>

static _Atomic uint64_t g_allocations;
static _Atomic uint64_t g_frees;

/* Provided by the linker for every symbol named in -Wl,--wrap=. */
void *__real_malloc(size_t size);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *ptr, size_t size);
void *__real_aligned_alloc(size_t alignment, size_t size);
int __real_posix_memalign(void **ptr, size_t alignment, size_t size);
void __real_free(void *ptr);

void *__wrap_malloc(size_t size);
void *__wrap_calloc(size_t n, size_t size);
void *__wrap_realloc(void *ptr, size_t size);
void *__wrap_aligned_alloc(size_t alignment, size_t size);
int __wrap_posix_memalign(void **ptr, size_t alignment, size_t size);
void __wrap_free(void *ptr);

void *__wrap_malloc(size_t size)
{
    atomic_fetch_add_explicit(&g_allocations, 1u, memory_order_relaxed);
    return __real_malloc(size);
}

void *__wrap_calloc(size_t n, size_t size)
{
    atomic_fetch_add_explicit(&g_allocations, 1u, memory_order_relaxed);
    return __real_calloc(n, size);
}

void *__wrap_realloc(void *ptr, size_t size)
{
    atomic_fetch_add_explicit(&g_allocations, 1u, memory_order_relaxed);
    return __real_realloc(ptr, size);
}

void *__wrap_aligned_alloc(size_t alignment, size_t size)
{
    atomic_fetch_add_explicit(&g_allocations, 1u, memory_order_relaxed);
    return __real_aligned_alloc(alignment, size);
}

int __wrap_posix_memalign(void **ptr, size_t alignment, size_t size)
{
    atomic_fetch_add_explicit(&g_allocations, 1u, memory_order_relaxed);
    return __real_posix_memalign(ptr, alignment, size);
}

void __wrap_free(void *ptr)
{
    if (ptr != NULL)
        atomic_fetch_add_explicit(&g_frees, 1u, memory_order_relaxed);
    __real_free(ptr);
}

void alloc_count_reset(void)
{
    atomic_store(&g_allocations, 0u);
    atomic_store(&g_frees, 0u);
}

uint64_t alloc_count_allocations(void)
{
    return atomic_load(&g_allocations);
}

uint64_t alloc_count_frees(void)
{
    return atomic_load(&g_frees);
}
