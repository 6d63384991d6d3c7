/* select.h - the k-th smallest of a multiset of 64-bit keys that is seen
 * only through histograms: keys spread over tiles (or files, or ranks)
 * that are never gathered in one place. Radix selection, 16 bits a pass:
 * at most four passes, each one histogram of 65 536 counts summed over
 * the parts, so the memory does not depend on the number of keys, and the
 * result does not depend on how the keys are split.
 */
#ifndef WPD_CORE_SELECT_H
#define WPD_CORE_SELECT_H

#include <stdint.h>

#define WPD_SELECT_BUCKETS 65536

/* Adds one to hist[(k >> shift) & 0xffff] for every key k of the multiset
 * with (k & mask) == prefix. */
typedef void (*wpd_select_count_fn)(void *arg, uint64_t mask, uint64_t prefix, int shift,
                                    uint64_t *hist);

/* The key of 0-based rank k in ascending order (k < the number of keys),
 * and in *below (may be NULL) how many keys are smaller than it. hist:
 * scratch of WPD_SELECT_BUCKETS counts. */
uint64_t wpd_select_kth(wpd_select_count_fn count, void *arg, uint64_t k, uint64_t *below,
                        uint64_t *hist);

#endif
