/* record_cache.h - decoded records of a compressed input, kept on disk for
 * the passes after the first.
 *
 * The engine reads its inputs three times (scan, tile, records). Decoding
 * LAZ costs about ten times reading LAS, so the first pass over a LAZ file
 * keeps what it decodes: the raw point records, at their index times the
 * record length, in a file of its own in the run's private directory
 * "<base>/wpd-cache-<pid>-XXXXXX" (made by the caller with common/tmpdir.h:
 * removed on every exit path, swept after a kill; one directory for all
 * inputs, since a run may read thousands). The file is opened for each
 * read or write, not held: a cloud of thousands of inputs holds no file
 * descriptor per input. Later passes read the records back with one
 * pread where every chunk they touch is complete, and decode only what is
 * not. The records are stored as decoded, not compressed again: a fast
 * zstd level costs half a decode or more and the cache lives one run
 * (docs/engine.md, "Compressed inputs").
 *
 * A chunk (the compressor's unit: decoding starts at its first point) is
 * complete once one reader has decoded all of its points and written
 * them; readers of one file share its cache from several threads: writes
 * of the same chunk carry the same bytes, and completion is a flag set
 * after the write.
 */
#ifndef WPD_RECORD_CACHE_H
#define WPD_RECORD_CACHE_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

typedef struct wpd_record_cache wpd_record_cache;

/* The chunk holding record index in a chunk table: the last c < nchunks
 * with first[c] <= index (first: nchunks + 1 ascending indices). */
static inline uint64_t wpd_chunk_holding(const uint64_t *first, uint64_t nchunks,
                                         uint64_t index)
{
    uint64_t lo = 0, hi = nchunks;
    while (hi - lo > 1) {
        uint64_t mid = lo + (hi - lo) / 2;
        if (first[mid] <= index)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* Creates an empty cache, the file "<dir>/records-<id>", for the records
 * of input `path` (named in messages): nchunks chunks, chunk c holding the
 * records first[c] .. first[c + 1] - 1 (first: nchunks + 1 ascending
 * indices, copied), record_length bytes each. Returns NULL with err set
 * (WPD_E_IO naming the file, WPD_E_MEMORY). */
wpd_record_cache *wpd_record_cache_create(const char *dir, int id, const char *path,
                                          uint32_t record_length, const uint64_t *first,
                                          uint64_t nchunks, wpd_error *err);

/* Writes the n records at rec as records index .. index + n - 1. Returns 0,
 * or -1 with err set (WPD_E_IO naming the cache file: disk full ...). */
int wpd_record_cache_write(wpd_record_cache *c, uint64_t index, const uint8_t *rec, size_t n,
                           wpd_error *err);

/* Marks chunk `chunk` complete: every record of it was written. */
void wpd_record_cache_complete(wpd_record_cache *c, uint64_t chunk);

/* How many of the records index .. index + n - 1, from the first on, lie
 * in complete chunks (0 when index's chunk is not complete). */
size_t wpd_record_cache_held(const wpd_record_cache *c, uint64_t index, size_t n);

/* Reads records index .. index + n - 1 (covered) into rec. Returns 0, or -1
 * with err set (WPD_E_IO). */
int wpd_record_cache_read(wpd_record_cache *c, uint64_t index, uint8_t *rec, size_t n,
                          wpd_error *err);

/* Records read back from the cache so far (for tests and the report). */
uint64_t wpd_record_cache_hits(const wpd_record_cache *c);

/* Removes the file and frees c. NULL is allowed. */
void wpd_record_cache_free(wpd_record_cache *c);

#endif
