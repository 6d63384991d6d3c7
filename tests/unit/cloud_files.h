/* cloud_files.h - what the reader tests of every format share (test_las*.c,
 * test_ply*.c through las_files.h and ply_files.h): paths in the test's
 * temporary directory, raw files, and every point of an open reader. */
#ifndef WPD_TEST_CLOUD_FILES_H
#define WPD_TEST_CLOUD_FILES_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/reader.h"

/* out = <test temp dir>/name; returns out. */
char *cf_tmp_path(char *out, size_t size, const char *name);

/* Writes len bytes to path. Returns 0 or -1. */
int cf_write_file(const char *path, const void *data, size_t len);

/* The whole file at path: malloc'd, *len bytes; NULL when it cannot be read. */
uint8_t *cf_read_file(const char *path, size_t *len);

/* All points of a file: concatenated records and decoded x, y, z. */
typedef struct cf_cloud {
    size_t n;
    uint32_t record_size;
    uint8_t *records;
    double *xyz;
    uint64_t dropped;          /* points the reader dropped (non-finite) */
} cf_cloud;

/* Reads every point of r into c in batches of batch_cap (small ones
 * exercise the batch edges). Returns 0, or -1 with err set by the reader,
 * or -1 (err untouched) when out of memory or when the reader delivers
 * more points than its header announced. */
int cf_read_all(wpd_reader *r, cf_cloud *c, size_t batch_cap, wpd_error *err);
void cf_cloud_free(cf_cloud *c);

#endif
