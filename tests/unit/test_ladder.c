/* test_ladder.c - the voxel ladder of the scan (method/ladder.h): exact counts
 * at every scale, merged from parts on threads or from the packed ladders of
 * other ranks, and the sampled finer scales. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "method/ladder.h"

/* The next number of a linear congruential sequence, in [0, 1): the
 * tests' clouds, the same from run to run. */
static double uniform(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / (double)(1ull << 53);
}

/* Counting a cloud in parts and merging the ladders gives the counts of one
 * stream over all points, whatever the split: the scan and the in-memory
 * radius count on several threads. A small cap forces coarsening, at
 * different moments in each part. */
TEST(ladder_merge_equals_one_stream)
{
    enum { N = 60000, CAP = 1500 };
    double *xyz = malloc(3 * N * sizeof *xyz);
    uint64_t s = 7;
    for (int i = 0; i < 3 * N; i++) {
        xyz[i] = uniform(&s) * (i % 3 == 2 ? 5.0 : 100.0);
    }
    const double extent[3] = {100, 100, 5};
    const double wanted = 1e9; /* with the sample ladder */
    double e1[WPD_MAX_SCALES], e2[WPD_MAX_SCALES];
    uint64_t m1[WPD_MAX_SCALES], m2[WPD_MAX_SCALES];
    int n1 = 0, n2 = 0, k1 = 0, k2 = 0;
    wpd_ladder one, a, b;
    CHECK(wpd_ladder_init(&one, extent, N, CAP, wanted) == 0);
    for (int i = 0; i < N; i++)
        CHECK(wpd_ladder_put(&one, xyz + 3 * i) == 0);
    CHECK(wpd_ladder_finish(&one, e1, m1, &n1, &k1) == 0);
    /* a: a tenth of the points, one level; b: the rest, coarser */
    CHECK(wpd_ladder_init(&a, extent, N, CAP, wanted) == 0 &&
          wpd_ladder_init(&b, extent, N, CAP, wanted) == 0);
    for (int i = 0; i < N; i++)
        CHECK(wpd_ladder_put(i < N / 10 ? &a : &b, xyz + 3 * i) == 0);
    CHECK_MSG(a.all.level < b.all.level, "levels %d %d", a.all.level, b.all.level);
    CHECK(wpd_ladder_merge(&a, &b) == 0);
    CHECK(wpd_ladder_finish(&a, e2, m2, &n2, &k2) == 0);
    CHECK_MSG(n1 == n2 && k1 == k2, "scales %d (%d estimated) vs %d (%d)", n1, k1, n2, k2);
    for (int i = 0; i < n1 && i < n2; i++)
        CHECK_MSG(e1[i] == e2[i] && m1[i] == m2[i], "scale %d: %g %llu vs %g %llu", i, e1[i],
                  (unsigned long long)m1[i], e2[i], (unsigned long long)m2[i]);
    wpd_ladder_free(&one);
    wpd_ladder_free(&a);
    wpd_ladder_free(&b);
    free(xyz);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Occupied voxels of edge `edge` among n points, counted by sorting their
 * keys (the ladder's own voxel arithmetic: index = (uint64_t)(p / edge)). */
static uint64_t distinct_voxels(const double *xyz, size_t n, double edge, uint64_t *key)
{
    double inv = 1.0 / edge;
    for (size_t i = 0; i < n; i++) {
        const double *p = xyz + 3 * i;
        key[i] = (uint64_t)(p[0] * inv) | (uint64_t)(p[1] * inv) << 21 |
                 (uint64_t)(p[2] * inv) << 42;
    }
    qsort(key, n, sizeof *key, cmp_u64);
    uint64_t m = 0;
    for (size_t i = 0; i < n; i++)
        m += i == 0 || key[i] != key[i - 1];
    return m;
}

/* The ladder's counts are exact at every scale for points in scan order,
 * whose lines come back to the voxels of the lines before (what the
 * recent-key filter skips), with a cap small enough to coarsen the set
 * several times mid-stream (when the filter must forget its keys). */
TEST(ladder_counts_exact_on_scan_lines)
{
    enum { LINES = 400, PER_LINE = 500, N = LINES * PER_LINE, CAP = 1024 };
    double *xyz = malloc(3 * (size_t)N * sizeof *xyz);
    uint64_t *key = malloc((size_t)N * sizeof *key);
    CHECK(xyz && key);
    for (int l = 0; l < LINES && xyz; l++)
        for (int j = 0; j < PER_LINE; j++) {
            double *p = xyz + 3 * ((size_t)l * PER_LINE + (size_t)j);
            int along = l % 2 ? PER_LINE - 1 - j : j; /* back and forth */
            p[0] = 0.2 * along;
            p[1] = 0.25 * l + 0.01 * (j % 7);
            p[2] = 50 + 45 * sin(0.07 * along + 0.3 * l); /* a volume: many voxels */
        }
    const double extent[3] = {100, 100, 100};
    double e[WPD_MAX_SCALES];
    uint64_t m[WPD_MAX_SCALES];
    int n = 0, k = 0;
    wpd_ladder l;
    CHECK(wpd_ladder_init(&l, extent, N, CAP, 1000) == 0);
    for (size_t i = 0; xyz && i < N; i++)
        CHECK(wpd_ladder_put(&l, xyz + 3 * i) == 0);
    CHECK_MSG(l.all.level >= 2, "the set coarsened %d times", l.all.level);
    CHECK(wpd_ladder_finish(&l, e, m, &n, &k) == 0);
    CHECK(n > 3 && k == 0);
    for (int i = 0; xyz && key && i < n; i++) {
        uint64_t exact = distinct_voxels(xyz, N, e[i], key);
        CHECK_MSG(m[i] == exact, "edge %g: ladder %llu, exact %llu", e[i],
                  (unsigned long long)m[i], (unsigned long long)exact);
    }
    wpd_ladder_free(&l);
    free(key);
    free(xyz);
}

/* A ladder counted in parts on other processes and merged from its packed
 * bytes (wpd_ladder_merge_packed, the ranks of an MPI run) gives the counts
 * of one ladder over all points, exact and sampled scales alike; bytes that
 * are no ladder are refused. */
TEST(ladder_merge_packed_equals_one_ladder)
{
    enum { N = 300000, PARTS = 3 };
    double *xyz = malloc(3 * (size_t)N * sizeof *xyz);
    CHECK(xyz != NULL);
    if (!xyz)
        return;
    uint64_t s = 5;
    /* A surface, and above it (the second half of the points) a volume: the
     * parts' ladders coarsen to different levels. */
    for (size_t i = 0; i < N; i++) {
        double u[3];
        for (int k = 0; k < 3; k++)
            u[k] = uniform(&s) * 300.0;
        xyz[3 * i] = u[0], xyz[3 * i + 1] = u[1];
        xyz[3 * i + 2] = i < N / 2 ? 30 + 20 * sin(u[0] / 40) * cos(u[1] / 25) : u[2] / 5;
    }
    const double extent[3] = {300, 300, 60};
    for (int sampled = 0; sampled <= 2; sampled++) {
        /* Without the samples: a small cap, so the parts coarsen; with one
         * or two, a cap whose sampled blocks hold enough voxels for an
         * estimate. */
        size_t cap = sampled ? 1 << 16 : 4096;
        double wanted = sampled == 2 ? 1e7 : sampled ? 1e5 : 100, e[2][WPD_MAX_SCALES];
        uint64_t m[2][WPD_MAX_SCALES];
        int n[2], k[2];
        wpd_ladder one, part[PARTS];
        CHECK(wpd_ladder_init(&one, extent, N, cap, wanted) == 0);
        for (int p = 0; p < PARTS; p++)
            CHECK(wpd_ladder_init(&part[p], extent, N, cap, wanted) == 0);
        for (size_t i = 0; i < N; i++) {
            CHECK(wpd_ladder_put(&one, xyz + 3 * i) == 0);
            /* Parts of unequal sizes: they coarsen to different levels. */
            int p = i < N / 100 ? 0 : i < N / 2 ? 1 : 2;
            CHECK(wpd_ladder_put(&part[p], xyz + 3 * i) == 0);
        }
        CHECK(one.sampling == sampled);
        CHECK_MSG(sampled || part[0].all.level < part[2].all.level,
                  "levels %d %d %d", part[0].all.level, part[2].all.level, one.all.level);
        for (int p = 1; p < PARTS; p++) {
            uint8_t *buf = NULL;
            size_t len = 0;
            CHECK(wpd_ladder_pack(&part[p], &buf, &len) == 0);
            CHECK(wpd_ladder_merge_packed(&part[0], buf, len) == 0);
            if (p == 1 && len > 16) {
                CHECK(wpd_ladder_merge_packed(&part[0], buf, len - 8) == -1); /* cut short */
                ((uint64_t *)buf)[1] = UINT64_MAX / 16;                       /* a count that lies */
                CHECK(wpd_ladder_merge_packed(&part[0], buf, len) == -1);
            }
            free(buf);
        }
        CHECK(wpd_ladder_finish(&one, e[0], m[0], &n[0], &k[0]) == 0);
        CHECK(wpd_ladder_finish(&part[0], e[1], m[1], &n[1], &k[1]) == 0);
        CHECK_MSG(n[0] == n[1] && k[0] == k[1], "sampled %d: %d/%d scales, %d/%d estimated",
                  sampled, n[0], n[1], k[0], k[1]);
        CHECK((sampled > 0) == (k[0] > 0));
        for (int i = 0; i < n[0] && i < n[1]; i++)
            CHECK_MSG(e[0][i] == e[1][i] && m[0][i] == m[1][i], "scale %d: %g %llu / %g %llu", i,
                      e[0][i], (unsigned long long)m[0][i], e[1][i], (unsigned long long)m[1][i]);
        wpd_ladder_free(&one);
        for (int p = 0; p < PARTS; p++)
            wpd_ladder_free(&part[p]);
    }
    free(xyz);
}

/* The scales finer than the exact ladder's, estimated from the sampled
 * blocks (one sample ladder, then two), agree with exact counts on a
 * surface; a target the exact scales can hold gets no estimate, and the
 * exact counts are the same either way. */
TEST(ladder_sample_estimates_fine_scales)
{
    enum { N = 4000000, CAP = 1 << 16 };
    double *xyz = malloc(3 * (size_t)N * sizeof *xyz);
    uint64_t s = 11;
    for (size_t i = 0; i < N; i++) {
        double u[2];
        for (int k = 0; k < 2; k++)
            u[k] = uniform(&s) * 400.0;
        xyz[3 * i] = u[0], xyz[3 * i + 1] = u[1];
        xyz[3 * i + 2] = 20 + 10 * sin(u[0] / 60) * cos(u[1] / 45); /* a rolling surface */
    }
    const double extent[3] = {400, 400, 40};
    const double wanted[3] = {1000, 1e5, 1e9};
    double e[3][WPD_MAX_SCALES];
    uint64_t m[3][WPD_MAX_SCALES];
    int n[3], k[3];
    for (int run = 0; run < 3; run++) {
        wpd_ladder l;
        CHECK(wpd_ladder_init(&l, extent, N, CAP, wanted[run]) == 0);
        CHECK(l.sampling == run);
        for (size_t i = 0; i < N; i++)
            CHECK(wpd_ladder_put(&l, xyz + 3 * i) == 0);
        CHECK(wpd_ladder_finish(&l, e[run], m[run], &n[run], &k[run]) == 0);
        wpd_ladder_free(&l);
    }
    CHECK_MSG(k[0] == 0 && k[1] == 2 && k[2] == 4, "estimated scales %d, %d and %d", k[0],
              k[1], k[2]);
    for (int run = 1; run < 3; run++) {
        CHECK(n[run] == n[0] + k[run]);
        for (int i = 0; i < n[0] && n[run] == n[0] + k[run]; i++)
            CHECK(e[0][i] == e[run][i + k[run]] && m[0][i] == m[run][i + k[run]]);
    }
    /* Both samples' sets travel: counted in three parts, two of them packed
     * and merged (the ranks of an MPI run), the same counts and estimates. */
    wpd_ladder part[3];
    for (int q = 0; q < 3; q++)
        CHECK(wpd_ladder_init(&part[q], extent, N, CAP, wanted[2]) == 0);
    for (size_t i = 0; i < N; i++)
        CHECK(wpd_ladder_put(&part[i < N / 7 ? 0 : i < N / 2 ? 1 : 2], xyz + 3 * i) == 0);
    for (int q = 1; q < 3; q++) {
        uint8_t *buf = NULL;
        size_t len = 0;
        CHECK(wpd_ladder_pack(&part[q], &buf, &len) == 0);
        CHECK(wpd_ladder_merge_packed(&part[0], buf, len) == 0);
        free(buf);
    }
    double pe[WPD_MAX_SCALES];
    uint64_t pm[WPD_MAX_SCALES];
    int pn, pk;
    CHECK(wpd_ladder_finish(&part[0], pe, pm, &pn, &pk) == 0);
    CHECK_MSG(pn == n[2] && pk == k[2], "merged: %d scales, %d estimated", pn, pk);
    for (int i = 0; i < pn && pn == n[2]; i++)
        CHECK(pe[i] == e[2][i] && pm[i] == m[2][i]);
    for (int q = 0; q < 3; q++)
        wpd_ladder_free(&part[q]);
    /* The second sample's ladder gives the first's scales as they were. */
    for (int i = 0; i < k[1] && k[2] == k[1] + 2; i++)
        CHECK(e[1][i] == e[2][i + 2] && m[1][i] == m[2][i + 2]);
    for (int i = 0; i < k[2]; i++) {
        uint64_t exact = 0;
        wpd_error err = {0};
        CHECK(wpd_voxel_counts(xyz, N, &e[2][i], 1, &exact, 2, &err) == 0);
        double rel = (double)m[2][i] / (double)exact - 1;
        CHECK_MSG(fabs(rel) < 0.05, "edge %g: estimate %llu, exact %llu", e[2][i],
                  (unsigned long long)m[2][i], (unsigned long long)exact);
    }
    free(xyz);
}
