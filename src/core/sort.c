/* sort.c - LSD radix sort of (uint64 key, uint32 value) pairs. */
#include "core/sort.h"

#include <omp.h>
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

/* Counts of every digit in each thread's share, turned into each share's
 * first destination per digit: shares of one digit follow each other in
 * thread order, as the sequential pass would place them. */
static void share_offsets(size_t (*count)[DIGIT_SIZE], int nt)
{
    size_t sum = 0;
    for (size_t d = 0; d < DIGIT_SIZE; d++)
        for (int t = 0; t < nt; t++) {
            size_t c = count[t][d];
            count[t][d] = sum;
            sum += c;
        }
}

void wpd_radix_sort_u64_threads(uint64_t *key, uint32_t *val, size_t n, int bits,
                                uint64_t *tmp_key, uint32_t *tmp_val, int threads)
{
    enum { MAX_SHARES = 64 };
    threads = threads > MAX_SHARES ? MAX_SHARES : threads;
    size_t (*count)[DIGIT_SIZE] = threads > 1 && n >= WPD_SORT_PARALLEL_MIN
                                      ? malloc((size_t)threads * sizeof *count)
                                      : NULL;
    if (!count) {
        wpd_radix_sort_u64(key, val, n, bits, tmp_key, tmp_val);
        return;
    }
    int passes = (bits + DIGIT_BITS - 1) / DIGIT_BITS;
#pragma omp parallel num_threads(threads)
    {
        int t = omp_get_thread_num(), nt = omp_get_num_threads();
        size_t b = n * (size_t)t / (size_t)nt, e = n * (size_t)(t + 1) / (size_t)nt;
        uint64_t *src_k = key, *dst_k = tmp_key;
        uint32_t *src_v = val, *dst_v = tmp_val;
        for (int p = 0; p < passes; p++) {
            int shift = p * DIGIT_BITS;
            size_t *mine = count[t];
            memset(mine, 0, sizeof count[0]);
            for (size_t i = b; i < e; i++)
                mine[(src_k[i] >> shift) & (DIGIT_SIZE - 1)]++;
#pragma omp barrier
#pragma omp single
            share_offsets(count, nt);
            for (size_t i = b; i < e; i++) {
                size_t at = mine[(src_k[i] >> shift) & (DIGIT_SIZE - 1)]++;
                dst_k[at] = src_k[i];
                dst_v[at] = src_v[i];
            }
#pragma omp barrier
            uint64_t *tk = src_k; src_k = dst_k; dst_k = tk;
            uint32_t *tv = src_v; src_v = dst_v; dst_v = tv;
        }
        if (src_k != key) {
            memcpy(key + b, src_k + b, (e - b) * sizeof *key);
            memcpy(val + b, src_v + b, (e - b) * sizeof *val);
        }
    }
    free(count);
}
