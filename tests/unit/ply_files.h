/* ply_files.h - helpers of the PLY unit tests (test_ply.c,
 * test_ply_lenient.c): files written to the test's temporary directory and
 * read back whole through the public reader API. */
#ifndef WPD_TEST_PLY_FILES_H
#define WPD_TEST_PLY_FILES_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/reader.h"

#include "cloud_files.h"

/* Opens path and reads every point. Returns 0, or -1 with err set. */
int pf_read_all(const char *path, cf_cloud *c, wpd_error *err);

/* 1 if a and b hold the same records and coordinates. */
int pf_clouds_equal(const cf_cloud *a, const cf_cloud *b);

/* 1 if opening (or, if it opens, reading) path fails with a message that
 * starts with the path and contains want; the message is copied to msg. */
int pf_fails_with(const char *path, const char *want, char *msg, size_t msg_size);

#endif
