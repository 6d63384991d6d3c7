/* sort.h - sorting (key, value) pairs: the building block of the grids and
 * of every deterministic ordering in the WPD core.
 *
 * The sort is stable, so the order it gives depends only on the keys and,
 * for equal keys, on the input order, never on the number of threads.
 */
#ifndef WPD_CORE_SORT_H
#define WPD_CORE_SORT_H

#include <stddef.h>
#include <stdint.h>

/* Stable LSD radix sort of n pairs by the low `bits` bits of key (bits in
 * 1..64; higher bits must be zero). key/val are sorted in place; tmp_key and
 * tmp_val are scratch of n entries each. */
void wpd_radix_sort_u64(uint64_t *key, uint32_t *val, size_t n, int bits,
                        uint64_t *tmp_key, uint32_t *tmp_val);

/* The same sort, the same result, on up to `threads` threads (each counts
 * and scatters its own share of every pass; the shares are placed in
 * order, so the sort stays stable). Sequential below WPD_SORT_PARALLEL_MIN
 * pairs, for threads <= 1, or when the counters cannot be allocated. Not
 * from inside a parallel region (it would run on one thread). */
#define WPD_SORT_PARALLEL_MIN ((size_t)1 << 17)
void wpd_radix_sort_u64_threads(uint64_t *key, uint32_t *val, size_t n, int bits,
                                uint64_t *tmp_key, uint32_t *tmp_val, int threads);

/* The first index i of a[0..n-1] (ascending) with a[i] >= key; n if none. */
static inline size_t wpd_lower_bound_u64(const uint64_t *a, size_t n, uint64_t key)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (a[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* The first index i of a[0..n-1] (ascending) with a[i] >= key; n if none. */
static inline size_t wpd_lower_bound_u32(const uint32_t *a, size_t n, uint64_t key)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (a[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

#endif
