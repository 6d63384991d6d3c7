/* sort.c - LSD radix sort of (uint64 key, uint32 value) pairs. */
#include "core/sort.h"

#include <string.h>

#define DIGIT_BITS 11
#define DIGIT_SIZE (1u << DIGIT_BITS)

void wpd_radix_sort_u64(uint64_t *key, uint32_t *val, size_t n, int bits,
                        uint64_t *tmp_key, uint32_t *tmp_val)
{
    uint64_t *src_k = key, *dst_k = tmp_key;
    uint32_t *src_v = val, *dst_v = tmp_val;
    size_t count[DIGIT_SIZE];
    int passes = (bits + DIGIT_BITS - 1) / DIGIT_BITS;
    for (int p = 0; p < passes; p++) {
        int shift = p * DIGIT_BITS;
        memset(count, 0, sizeof count);
        for (size_t i = 0; i < n; i++)
            count[(src_k[i] >> shift) & (DIGIT_SIZE - 1)]++;
        size_t sum = 0;
        for (size_t d = 0; d < DIGIT_SIZE; d++) {
            size_t c = count[d];
            count[d] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; i++) {
            size_t at = count[(src_k[i] >> shift) & (DIGIT_SIZE - 1)]++;
            dst_k[at] = src_k[i];
            dst_v[at] = src_v[i];
        }
        uint64_t *tk = src_k; src_k = dst_k; dst_k = tk;
        uint32_t *tv = src_v; src_v = dst_v; dst_v = tv;
    }
    if (src_k != key) {
        memcpy(key, src_k, n * sizeof *key);
        memcpy(val, src_v, n * sizeof *val);
    }
}
