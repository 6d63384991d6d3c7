/* sort.h - sorting (key, value) pairs: the building block of the grids and
 * of every deterministic ordering in the WPD core.
 *
 * Both sorts are exact and stable where it matters, so the order they give
 * depends only on the keys (and, for equal keys, on the input order), never
 * on the number of threads.
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

/* Sorts n pairs by full 64-bit key, for keys that are spread evenly over
 * the 64-bit range (hash values): one bucketing pass on the top bits, then
 * an insertion sort inside each (tiny) bucket. Equal keys keep their input
 * order. Scratch as above. Returns 0, or -1 if out of memory. */
int wpd_sort_hashed_u64(uint64_t *key, uint32_t *val, size_t n,
                        uint64_t *tmp_key, uint32_t *tmp_val);

#endif
