/* test_record_cache.c - compressed inputs decoded once (io/record_cache.h
 * through wpd_cloud_cache_records): a first pass in stretches that cut
 * chunks gives the twin's records and fills the cache; a second pass, in
 * other stretches, gives them again from the cache alone; a LAS file gets
 * no cache; closing the cloud removes the cache's directory. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "io/cloud.h"

/* Reads records [from, to) of cloud c through a reopened copy into rec
 * (record_size bytes each, at their index). Returns 0 or -1. */
static int read_stretch(const wpd_cloud *c, uint64_t from, uint64_t to, uint8_t *rec,
                        uint32_t record_size, wpd_error *err)
{
    wpd_cloud *copy = wpd_cloud_reopen(c, err);
    wpd_batch b;
    if (!copy || wpd_batch_init(&b, 777, record_size)) {
        wpd_cloud_close(copy);
        return -1;
    }
    int rc = wpd_cloud_seek_stretch(copy, from, to - from, err);
    uint64_t at = from;
    for (long got; rc == 0 && (got = wpd_cloud_read(copy, &b, NULL, err)) != 0; at += (uint64_t)got)
        if (got < 0 || at + (uint64_t)got > to)
            rc = -1;
        else
            memcpy(rec + at * record_size, b.records, (size_t)got * record_size);
    wpd_batch_free(&b);
    wpd_cloud_close(copy);
    return rc == 0 && at == to ? 0 : -1;
}

/* Reads every record of path in the stretches cut at cuts[] (ascending,
 * ending with the point count) into a fresh array. */
static uint8_t *read_in_stretches(const wpd_cloud *c, const uint64_t *cuts, int ncuts,
                                  uint32_t record_size, wpd_error *err)
{
    uint8_t *rec = calloc(cuts[ncuts - 1] ? cuts[ncuts - 1] : 1, record_size);
    uint64_t from = 0;
    for (int i = 0; rec && i < ncuts; from = cuts[i++])
        if (read_stretch(c, from, cuts[i], rec, record_size, err)) {
            free(rec);
            return NULL;
        }
    return rec;
}

static void check_file(int *failures_, const char *name, const uint64_t *first_cuts,
                       const uint64_t *second_cuts, int ncuts)
{
    char laz[1024], las[1024];
    snprintf(laz, sizeof laz, "%s/laz/%s.laz", test_data_dir(), name);
    snprintf(las, sizeof las, "%s/laz/%s.las", test_data_dir(), name);
    wpd_error err = {0};
    const char *one[1] = {las};
    wpd_cloud *twin = wpd_cloud_open(one, 1, &err);
    one[0] = laz;
    wpd_cloud *c = wpd_cloud_open(one, 1, &err);
    CHECK_MSG(c && twin, "%s: %s", name, err.msg);
    if (!c || !twin) {
        wpd_cloud_close(c), wpd_cloud_close(twin);
        return;
    }
    uint32_t size = wpd_cloud_header(c, 0)->schema.record_size;
    uint64_t n = wpd_cloud_count(c);
    CHECK_MSG(first_cuts[ncuts - 1] == n, "%s: %llu points", name, (unsigned long long)n);
    CHECK(wpd_cloud_cache_records(c, test_tmp_dir(), &err) == 0);
    CHECK(test_tmp_entries("wpd-cache-", NULL, 0) == 1);
    uint8_t *want = read_in_stretches(twin, first_cuts, ncuts, size, &err);
    uint8_t *first = read_in_stretches(c, first_cuts, ncuts, size, &err);
    uint64_t hits_first = wpd_cloud_cache_hits(c);
    uint8_t *second = read_in_stretches(c, second_cuts, ncuts, size, &err);
    uint64_t hits_second = wpd_cloud_cache_hits(c) - hits_first;
    CHECK_MSG(want && first && second, "%s: %s", name, err.msg);
    CHECK_MSG(want && first && !memcmp(want, first, n * size), "%s: first pass", name);
    CHECK_MSG(want && second && !memcmp(want, second, n * size), "%s: second pass", name);
    CHECK_MSG(hits_first == 0 && hits_second == n, "%s: %llu and %llu of %llu from the cache",
              name, (unsigned long long)hits_first, (unsigned long long)hits_second,
              (unsigned long long)n);
    free(want), free(first), free(second);
    wpd_cloud_close(c);
    CHECK_MSG(test_tmp_entries("wpd-cache-", NULL, 0) == 0, "%s: cache left behind", name);
    /* the twin is read, not decoded: no cache */
    CHECK(wpd_cloud_cache_records(twin, test_tmp_dir(), &err) == 0);
    CHECK(test_tmp_entries("wpd-cache-", NULL, 0) == 0);
    wpd_cloud_close(twin);
}

/* Point-wise chunks of 50 000 (lastools_fusa: 6), layered ones
 * (copcvalidator_ellipsoid-1.4: 2), and a COPC file's 65 variable chunks,
 * each cut in the middle of chunks, differently in the two passes. */
TEST(record_cache_decodes_each_chunk_once)
{
    if (!test_data_dir())
        return;
    static const uint64_t fusa1[] = {123456, 200000, 277573}, fusa2[] = {7, 150001, 277573};
    static const uint64_t ell1[] = {49990, 50010, 100000}, ell2[] = {1, 77777, 100000};
    static const uint64_t copc1[] = {17, 500, 1065}, copc2[] = {400, 1064, 1065};
    check_file(failures_, "lastools_fusa", fusa1, fusa2, 3);
    check_file(failures_, "copcvalidator_ellipsoid-1.4", ell1, ell2, 3);
    check_file(failures_, "laspy_simple_with_page.copc", copc1, copc2, 3);
}
