/* blobs.h - numbered byte arrays kept in files: per-tile working arrays
 * that would otherwise stay in memory for every tile at once (the exact
 * count's costs, candidates and decisions of a sweep). Each blob is one
 * file "b-<key>" in a private directory "wpd-blobs-<pid>-XXXXXX" under a
 * base directory (common/tmpdir.h: removed on every exit path, on
 * SIGINT/SIGTERM/SIGHUP, and by a later run's sweep after a kill), written
 * and read whole, uncompressed: they are read back soon, from the page
 * cache as a rule. Calls on different keys may run on different threads.
 * Errors: WPD_E_IO naming the file (disk full as such), WPD_E_MEMORY.
 */
#ifndef WPD_SPILL_BLOBS_H
#define WPD_SPILL_BLOBS_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

typedef struct wpd_blobs wpd_blobs;

/* Bytes of the blob sets counted in it (wpd_blobs_open), by the sizes
 * their puts recorded (a failed put counts 0, though a part may be on disk
 * until the set is closed): now, and the most at any time. Updated
 * atomically: sets on several threads may share one. */
typedef struct wpd_blobs_use {
    uint64_t now, peak;
} wpd_blobs_use;

/* A set of blobs 0 .. nkeys - 1, all empty, its bytes counted in *use until
 * it is closed (use may be NULL: not counted). Returns 0 with *out set, or
 * -1 with err set. */
int wpd_blobs_open(const char *base_dir, size_t nkeys, wpd_blobs_use *use, wpd_blobs **out,
                   wpd_error *err);

/* Removes every file and the directory, frees the set. NULL allowed. */
void wpd_blobs_close(wpd_blobs *b);

/* Replaces blob key by bytes bytes of data and frees data (malloc'd), on
 * failure too. Returns 0 or -1 with err set. */
int wpd_blobs_put(wpd_blobs *b, size_t key, void *data, size_t bytes, wpd_error *err);

/* Blob key into *data (malloc'd, at least one byte; the caller frees it)
 * and its size into *bytes (0 for a blob never put). Returns 0 or -1 with
 * err set (nothing allocated). */
int wpd_blobs_get(const wpd_blobs *b, size_t key, void **data, size_t *bytes, wpd_error *err);

#endif
