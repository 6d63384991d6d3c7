/* ply_files.h - helpers of the PLY unit tests (test_ply.c,
 * test_ply_lenient.c): files written to the test's temporary directory and
 * read back whole through the public reader API. */
#ifndef WPD_TEST_PLY_FILES_H
#define WPD_TEST_PLY_FILES_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/reader.h"

/* out = <test temp dir>/name. */
void pf_tmp_path(char *out, size_t size, const char *name);

/* Writes len bytes to path. Returns 0 or -1. */
int pf_write_bytes(const char *path, const void *data, size_t len);

/* All points of a file: concatenated records and coordinates. */
typedef struct pf_cloud {
    size_t n;
    uint32_t record_size;
    uint8_t *records;
    double *xyz;
    uint64_t dropped;
} pf_cloud;

void pf_cloud_free(pf_cloud *c);

/* Reads every point of an open reader in batches of batch_cap. Returns 0,
 * or -1 with err set. */
int pf_read_all_from(wpd_reader *r, pf_cloud *c, size_t batch_cap, wpd_error *err);

/* Opens path and reads every point. Returns 0, or -1 with err set. */
int pf_read_all(const char *path, pf_cloud *c, wpd_error *err);

/* 1 if a and b hold the same records and coordinates. */
int pf_clouds_equal(const pf_cloud *a, const pf_cloud *b);

/* 1 if opening (or, if it opens, reading) path fails with a message that
 * starts with the path and contains want; the message is copied to msg. */
int pf_fails_with(const char *path, const char *want, char *msg, size_t msg_size);

#endif
