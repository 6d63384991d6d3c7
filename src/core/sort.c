/* sort.c - LSD radix sort of (uint64 key, uint32 value) pairs. */
#include "core/sort.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

#define DIGIT_BITS 11
#define DIGIT_SIZE (1u << DIGIT_BITS)

/* Counts of every digit (bits shift.. of the key) among keys [b, e). */
static void count_digits(const uint64_t *key, size_t b, size_t e, int shift, size_t *count)
{
    memset(count, 0, DIGIT_SIZE * sizeof *count);
    for (size_t i = b; i < e; i++)
        count[(key[i] >> shift) & (DIGIT_SIZE - 1)]++;
}

/* Counts of every digit in each of nt shares, turned into each share's
 * first destination per digit: shares of one digit follow each other in
 * share order, as one sequential pass would place them. */
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

/* Pairs [b, e) to their destinations; count: the share's offsets per digit. */
static void scatter(const uint64_t *src_k, const uint32_t *src_v, uint64_t *dst_k,
                    uint32_t *dst_v, size_t b, size_t e, int shift, size_t *count)
{
    for (size_t i = b; i < e; i++) {
        size_t at = count[(src_k[i] >> shift) & (DIGIT_SIZE - 1)]++;
        dst_k[at] = src_k[i];
        dst_v[at] = src_v[i];
    }
}

void wpd_radix_sort_u64(uint64_t *key, uint32_t *val, size_t n, int bits,
                        uint64_t *tmp_key, uint32_t *tmp_val)
{
    uint64_t *src_k = key, *dst_k = tmp_key;
    uint32_t *src_v = val, *dst_v = tmp_val;
    size_t count[1][DIGIT_SIZE];
    int passes = (bits + DIGIT_BITS - 1) / DIGIT_BITS;
    for (int p = 0; p < passes; p++) {
        int shift = p * DIGIT_BITS;
        count_digits(src_k, 0, n, shift, count[0]);
        share_offsets(count, 1);
        scatter(src_k, src_v, dst_k, dst_v, 0, n, shift, count[0]);
        uint64_t *tk = src_k; src_k = dst_k; dst_k = tk;
        uint32_t *tv = src_v; src_v = dst_v; dst_v = tv;
    }
    if (src_k != key) {
        memcpy(key, src_k, n * sizeof *key);
        memcpy(val, src_v, n * sizeof *val);
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
            count_digits(src_k, b, e, shift, count[t]);
#pragma omp barrier
#pragma omp single
            share_offsets(count, nt);
            scatter(src_k, src_v, dst_k, dst_v, b, e, shift, count[t]);
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
