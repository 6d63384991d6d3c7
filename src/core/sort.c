/* sort.c - radix and hashed-key sorts of (uint64 key, uint32 value) pairs. */
#include "core/sort.h"

#include <stdlib.h>
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

int wpd_sort_hashed_u64(uint64_t *key, uint32_t *val, size_t n,
                        uint64_t *tmp_key, uint32_t *tmp_val)
{
    if (n < 2)
        return 0;
    int b = 1;
    while (b < 26 && ((size_t)1 << b) < n)
        b++;
    size_t nb = (size_t)1 << b;
    uint32_t *start = calloc(nb + 1, sizeof *start);
    if (!start)
        return -1;
    int shift = 64 - b;
    for (size_t i = 0; i < n; i++)
        start[(key[i] >> shift) + 1]++;
    for (size_t d = 0; d < nb; d++)
        start[d + 1] += start[d];
    for (size_t i = 0; i < n; i++) {
        uint32_t at = start[key[i] >> shift]++;
        tmp_key[at] = key[i];
        tmp_val[at] = val[i];
    }
    /* start[d] now holds the end of bucket d, the beginning of bucket d+1. */
    size_t lo = 0;
    for (size_t d = 0; d < nb; d++) {
        size_t hi = start[d];
        for (size_t i = lo + 1; i < hi; i++) {
            uint64_t k = tmp_key[i];
            uint32_t v = tmp_val[i];
            size_t j = i;
            while (j > lo && tmp_key[j - 1] > k) {
                tmp_key[j] = tmp_key[j - 1];
                tmp_val[j] = tmp_val[j - 1];
                j--;
            }
            tmp_key[j] = k;
            tmp_val[j] = v;
        }
        lo = hi;
    }
    memcpy(key, tmp_key, n * sizeof *key);
    memcpy(val, tmp_val, n * sizeof *val);
    free(start);
    return 0;
}
