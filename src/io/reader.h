/* reader.h - streaming point readers, one interface for every format.
 *
 * A reader parses and validates the whole header when opened (nothing in the
 * header is trusted: every count and offset is checked against the file
 * size before anything is allocated or looped over), then streams points in
 * batches. Files with fixed-size records (LAS, binary PLY) can be positioned
 * at any point index, so several readers on one file can work in parallel.
 */
#ifndef WPD_READER_H
#define WPD_READER_H

#include "common/error.h"
#include "io/batch.h"
#include "io/schema.h"

typedef struct wpd_reader wpd_reader;

/* Opens path, recognises the format from its first bytes, parses the header.
 * Returns a reader, or NULL with err set (code WPD_E_INPUT for a malformed or
 * unsupported file, WPD_E_IO if it cannot be read). */
wpd_reader *wpd_reader_open(const char *path, wpd_error *err);

/* Header facts and record schema; valid until the reader is closed. */
const wpd_header *wpd_reader_header(const wpd_reader *r);

/* Fills b (whose record_size must equal the schema's) with up to b->cap
 * points, replacing its contents. Points whose x, y or z is not finite are
 * dropped and counted. Returns the number of points placed in b (0 only at
 * the end of the points), or -1 with err set; a file shorter than its header
 * promises is an error naming the file. */
long wpd_reader_read(wpd_reader *r, wpd_batch *b, wpd_error *err);

/* 1 if wpd_reader_seek works for this file (fixed-size records), else 0. */
int wpd_reader_can_seek(const wpd_reader *r);

/* Positions the reader so the next read starts at record index (0-based).
 * Returns 0, or -1 with err set. */
int wpd_reader_seek(wpd_reader *r, uint64_t index, wpd_error *err);

/* As wpd_reader_seek, and reads stop before record end (clamped to
 * [index, point count]): they return 0 there, so a batch never runs past
 * it even when points are dropped (a read fills its batch with finite
 * points and would otherwise take records beyond). The bound holds until
 * the next seek. */
int wpd_reader_seek_range(wpd_reader *r, uint64_t index, uint64_t end, wpd_error *err);

/* The chunk table of a compressed file that can seek: returns the number
 * of chunks and points *first at nchunks + 1 ascending record indices
 * (chunk c holds records first[c] .. first[c + 1] - 1), valid until r is
 * closed. Returns 0 and sets *first to NULL for other files. */
uint64_t wpd_reader_chunks(const wpd_reader *r, const uint64_t **first);

/* Cuts records [0, n) of a file whose chunk table is first (nchunks
 * chunks, as wpd_reader_chunks gives) into units of whole chunks, the unit
 * a reader decodes without decoding any point twice: consecutive chunks
 * while their records fit cap (> 0), a chunk of more alone. Writes the
 * units' first records to starts, then n (room for nchunks + 1 entries),
 * and returns the number of units. */
uint64_t wpd_chunk_units(const uint64_t *first, uint64_t nchunks, uint64_t n, uint64_t cap,
                         uint64_t *starts);

/* Asks for positions only (on = 1) or whole records again (0), from the
 * next read after a seek or chunk start on: a reader that can save work
 * (layered LAZ: only the X, Y and Z layers are decoded, the others not
 * even loaded) then fills b->xyz exactly but may leave the other fields
 * of b->records stale. Call it right after opening or seeking. Returns 1
 * when the reader saves work this way, 0 when it reads whole records
 * anyway. */
int wpd_reader_positions_only(wpd_reader *r, int on);

/* The records of a compressed file, decoded once for several passes
 * (record_cache.h). */
typedef struct wpd_record_cache wpd_record_cache;

/* Sets *out to a new, empty record cache for r's file, the file
 * "<dir>/records-<id>" (the caller frees it after every reader using it is
 * closed), or to NULL when caching saves nothing: formats whose records
 * are read, not decoded (LAS, PLY), and LAZ files that cannot be
 * positioned (no usable chunk table). Returns 0, or -1 with err set
 * (WPD_E_IO naming the file, WPD_E_MEMORY). */
int wpd_reader_new_cache(wpd_reader *r, const char *dir, int id, wpd_record_cache **out,
                         wpd_error *err);

/* From now on r keeps what it decodes in c (made by wpd_reader_new_cache
 * for the same file; NULL: no cache) and reads records back from it where
 * c holds them, instead of decoding. Readers of one file on several
 * threads may share c. Positions-only reading is then off: the records
 * must be whole. Call it right after opening. */
void wpd_reader_use_cache(wpd_reader *r, wpd_record_cache *c);

/* Number of records dropped so far for non-finite coordinates. */
uint64_t wpd_reader_dropped(const wpd_reader *r);

/* Closes the file and frees everything. NULL is allowed. */
void wpd_reader_close(wpd_reader *r);

#endif
