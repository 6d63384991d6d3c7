/* test_blobs.c - numbered byte arrays in files (spill/blobs.h): what is
 * put comes back, a blob never put is empty, a file cut short is an error
 * naming it, and closing removes the directory. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "spill/blobs.h"

TEST(blobs_round_trip_and_close_removes_everything)
{
    wpd_blobs *b;
    wpd_error err = {0};
    CHECK(wpd_blobs_open(test_tmp_dir(), 8, NULL, &b, &err) == 0);
    for (size_t key = 0; key < 8; key += 3) {
        size_t n = 1000 * key + 7;
        uint8_t *data = malloc(n);
        for (size_t i = 0; i < n; i++)
            data[i] = (uint8_t)(i * 31 + key);
        CHECK(wpd_blobs_put(b, key, data, n, &err) == 0);
    }
    for (size_t key = 0; key < 8; key++) {
        void *got;
        size_t n;
        CHECK(wpd_blobs_get(b, key, &got, &n, &err) == 0);
        size_t want = key % 3 ? 0 : 1000 * key + 7, wrong = n != want;
        for (size_t i = 0; !wrong && i < n; i++)
            wrong += ((uint8_t *)got)[i] != (uint8_t)(i * 31 + key);
        CHECK_MSG(!wrong, "blob %zu: %zu bytes", key, n);
        free(got);
    }
    char dir[1024], path[1200];
    CHECK(test_tmp_entries("wpd-blobs-", dir, sizeof dir) == 1);
    snprintf(path, sizeof path, "%s/b-3", dir);
    CHECK(truncate(path, 10) == 0);
    void *got = NULL;
    size_t n;
    CHECK(wpd_blobs_get(b, 3, &got, &n, &err) == -1 && got == NULL);
    CHECK_MSG(err.code == WPD_E_IO && strstr(err.msg, "b-3"), "%s", err.msg);
    wpd_blobs_close(b);
    CHECK(test_tmp_entries("wpd-blobs-", dir, sizeof dir) == 0);
}

TEST(blobs_count_their_bytes_now_and_at_the_peak)
{
    /* Two sets counted in one use, as the exact count's files and the
     * hints are: replacing a blob counts the difference, closing a set
     * takes its bytes off, the peak stays. */
    wpd_blobs *a, *b;
    wpd_error err = {0};
    wpd_blobs_use use = {0, 0};
    CHECK(wpd_blobs_open(test_tmp_dir(), 2, &use, &a, &err) == 0);
    CHECK(wpd_blobs_open(test_tmp_dir(), 2, &use, &b, &err) == 0);
    CHECK(wpd_blobs_put(a, 0, calloc(100, 1), 100, &err) == 0);
    CHECK(wpd_blobs_put(b, 1, calloc(50, 1), 50, &err) == 0);
    CHECK(use.now == 150 && use.peak == 150);
    CHECK(wpd_blobs_put(a, 0, calloc(30, 1), 30, &err) == 0);
    CHECK(use.now == 80 && use.peak == 150);
    wpd_blobs_close(a);
    CHECK(use.now == 50 && use.peak == 150);
    CHECK(wpd_blobs_put(b, 0, calloc(200, 1), 200, &err) == 0);
    CHECK(use.now == 250 && use.peak == 250);
    wpd_blobs_close(b);
    CHECK(use.now == 0 && use.peak == 250);
}
