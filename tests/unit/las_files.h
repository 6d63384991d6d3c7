/* las_files.h - LAS files for the LAS unit tests (test_las.c,
 * test_las_lenient.c): a small valid file built in memory, written to the
 * test's temporary directory, read back through the public reader API. */
#ifndef WPD_TEST_LAS_FILES_H
#define WPD_TEST_LAS_FILES_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/reader.h"

#include "cloud_files.h"

/* 1 if s starts with prefix. */
int lt_starts_with(const char *s, const char *prefix);

/* Writes p with header h to out (overwriting it) in batches of batch_cap.
 * Returns 0 or -1 with err set. */
int lt_write_points(const char *out, const wpd_header *h, const cf_cloud *p,
                    size_t batch_cap, wpd_error *err);

/* Opens path and reads everything; returns the first error (or code OK). */
wpd_error lt_open_and_read(const char *path);

/* A small valid LAS file. */
typedef struct lt_synth {
    uint8_t minor, pdrf;
    uint16_t record_length;
    uint32_t npoints;
    int with_vlr;        /* one 10-byte VLR "test"/7 */
} lt_synth;

/* Builds the file s describes into buf (zeroed, big enough); returns its
 * size. Points i = 0.. have X = 100 i, Y = -50 i, Z = 7 with scale 0.01 and
 * offset (1000, 2000, 0), return number i % 3 + 1; the header holds the
 * counts (legacy one 0 for PDRF 6-10) but no bounds. */
size_t lt_build_las(uint8_t *buf, const lt_synth *s);

/* Writes the bytes to a temp file named name and checks that opening or
 * reading it fails with an input error whose message starts with its path
 * and contains expect. */
void lt_expect_failure(int *failures_, const char *name, const uint8_t *bytes, size_t len,
                       const char *expect);

#endif
