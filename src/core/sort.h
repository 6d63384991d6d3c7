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

#endif
