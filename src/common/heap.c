/* heap.c - see heap.h. */
#include "common/heap.h"

#include <stdlib.h> /* defines __GLIBC__ with glibc */

#ifdef __GLIBC__
#include <malloc.h>
#endif

void wpd_heap_release(void)
{
#ifdef __GLIBC__
    malloc_trim(0);
#endif
}
