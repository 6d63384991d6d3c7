/* hugepage.c - large arrays on transparent huge pages (hugepage.h). */
#include "common/hugepage.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

void wpd_prefer_huge_pages(void *p, size_t bytes)
{
#ifdef MADV_HUGEPAGE
    if (!p || bytes < WPD_HUGE_MIN)
        return;
    long page = sysconf(_SC_PAGESIZE);
    uintptr_t size = page > 0 ? (uintptr_t)page : 4096;
    uintptr_t lo = ((uintptr_t)p + size - 1) / size * size;
    uintptr_t hi = ((uintptr_t)p + bytes) / size * size;
    if (hi > lo)
        (void)madvise((void *)lo, hi - lo, MADV_HUGEPAGE); /* advice: failure is harmless */
#else
    (void)p;
    (void)bytes;
#endif
}

void *wpd_malloc_large(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    wpd_prefer_huge_pages(p, bytes);
    return p;
}

void *wpd_calloc_large(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    size_t bytes = count * size;
    if (bytes < WPD_HUGE_MIN)
        return calloc(bytes ? count : 1, bytes ? size : 1);
    void *p = wpd_malloc_large(bytes);
    if (p)
        memset(p, 0, bytes);
    return p;
}

void *wpd_realloc_large(void *p, size_t bytes)
{
    void *q = realloc(p, bytes ? bytes : 1);
    wpd_prefer_huge_pages(q, bytes);
    return q;
}
