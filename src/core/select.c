/* select.c - radix selection over histograms (select.h). */
#include "core/select.h"

#include <string.h>

uint64_t wpd_select_kth(wpd_select_count_fn count, void *arg, uint64_t k, uint64_t *below,
                        uint64_t *hist)
{
    uint64_t mask = 0, prefix = 0, smaller = 0;
    for (int shift = 48; shift >= 0; shift -= 16) {
        memset(hist, 0, WPD_SELECT_BUCKETS * sizeof *hist);
        count(arg, mask, prefix, shift, hist);
        uint64_t b = 0;
        while (b + 1 < WPD_SELECT_BUCKETS && hist[b] <= k) {
            k -= hist[b];
            smaller += hist[b];
            b++;
        }
        prefix |= b << shift;
        mask |= (uint64_t)0xffff << shift;
    }
    if (below)
        *below = smaller;
    return prefix;
}
