/* hugepage.h - large arrays on transparent huge pages where the kernel
 * offers them.
 *
 * Many kernels run transparent huge pages in "madvise" mode: an anonymous
 * mapping gets 2 MiB pages only when asked. Every fresh 4 KiB page costs a
 * fault on first touch, and on virtual machines a fault costs several
 * microseconds: the grids, sorts and tiles of a run touch hundreds of MB
 * fresh, and their faults were 15-20 % of the CPU time of a run. Asking
 * for huge pages cuts them about 500-fold, for a slightly higher resident
 * size (memory is committed 2 MiB at a time).
 */
#ifndef WPD_COMMON_HUGEPAGE_H
#define WPD_COMMON_HUGEPAGE_H

#include <stddef.h>

/* Below this many bytes an array is left alone (a huge page would mostly
 * hold memory the array does not use). */
#define WPD_HUGE_MIN ((size_t)4 << 20)

/* Asks for huge pages behind the whole pages of [p, p + bytes), before
 * they are first touched; does nothing for NULL, for fewer than
 * WPD_HUGE_MIN bytes, or where the system has no such advice. Never fails:
 * the memory works the same either way. */
void wpd_prefer_huge_pages(void *p, size_t bytes);

/* malloc(bytes), with wpd_prefer_huge_pages on the result. Free with free(). */
void *wpd_malloc_large(size_t bytes);

/* calloc(count, size), with wpd_prefer_huge_pages before the zeroing
 * touches the pages; NULL when count * size overflows. Free with free(). */
void *wpd_calloc_large(size_t count, size_t size);

/* realloc(p, bytes), with wpd_prefer_huge_pages on the result (the part
 * already touched keeps its pages). Free with free(). */
void *wpd_realloc_large(void *p, size_t bytes);

#endif
