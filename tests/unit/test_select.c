/* test_select.c - radix selection over histograms (core/select.h): every
 * rank of multisets with ties, extreme keys and keys split over parts,
 * against a sort. */
#include <stdlib.h>
#include <string.h>

#include "core/hash.h"
#include "core/select.h"
#include "harness.h"

typedef struct parts {
    const uint64_t *key;
    size_t n;
    int nparts;
} parts;

/* Counts part by part, as the exact count counts tile by tile. */
static void count_parts(void *arg, uint64_t mask, uint64_t prefix, int shift, uint64_t *hist)
{
    const parts *p = arg;
    for (int part = 0; part < p->nparts; part++)
        for (size_t i = (size_t)part; i < p->n; i += (size_t)p->nparts)
            if ((p->key[i] & mask) == prefix)
                hist[(p->key[i] >> shift) & 0xffff]++;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Every rank of key[0..n-1] selected on nparts parts, checked against the
 * sorted keys (value and the count of smaller keys). */
static size_t wrong_ranks(const uint64_t *key, size_t n, int nparts)
{
    uint64_t *sorted = malloc(n * sizeof *sorted), *hist = malloc(WPD_SELECT_BUCKETS * 8);
    memcpy(sorted, key, n * sizeof *sorted);
    qsort(sorted, n, sizeof *sorted, cmp_u64);
    parts p = {key, n, nparts};
    size_t wrong = 0;
    for (size_t k = 0; k < n; k++) {
        uint64_t below, got = wpd_select_kth(count_parts, &p, k, &below, hist);
        size_t first = k;
        while (first > 0 && sorted[first - 1] == sorted[k])
            first--;
        wrong += got != sorted[k] || below != first;
    }
    free(sorted), free(hist);
    return wrong;
}

TEST(select_every_rank_matches_a_sort)
{
    enum { N = 600 };
    uint64_t key[N], st = 7;
    for (size_t i = 0; i < N; i++) {
        st = wpd_mix64(st + i);
        /* runs of ties, neighbours in the low bits, and the extremes */
        key[i] = i % 5 == 0 ? st % 7 : i % 5 == 1 ? (st & 0xffff0000ffffULL) : st;
    }
    key[0] = 0, key[1] = UINT64_MAX, key[2] = UINT64_MAX, key[3] = 0x7ff0000000000000ULL;
    for (int nparts = 1; nparts <= 7; nparts += 3)
        CHECK_MSG(wrong_ranks(key, N, nparts) == 0, "%d parts", nparts);
}

TEST(select_all_equal_keys)
{
    uint64_t key[100];
    for (int i = 0; i < 100; i++)
        key[i] = 0x3ff0000000000000ULL; /* 1.0 as a double */
    CHECK(wrong_ranks(key, 100, 3) == 0);
}
