/* read.h - the inputs of a run, read as one cloud (io/cloud.h). */
#ifndef WPD_RESAMPLE_READ_H
#define WPD_RESAMPLE_READ_H

#include "common/error.h"
#include "io/cloud.h"

/* Opens the files as one cloud. Compressed inputs are decoded once: the
 * first pass keeps their records in a private directory under tmpdir for
 * the tile and records passes (io/record_cache.h; docs/engine.md,
 * "Compressed inputs"). Returns the cloud, or NULL with err set. */
wpd_cloud *wpd_read_open(char *const *inputs, int ninputs, const char *tmpdir, wpd_error *err);

#endif
