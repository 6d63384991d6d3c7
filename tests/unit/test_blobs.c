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
    CHECK(wpd_blobs_open(test_tmp_dir(), 8, &b, &err) == 0);
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
