/* spill.h - per-tile spill files of point data, compressed with zstd.
 *
 * The tiler appends points to tiles in any order; each tile's points are
 * buffered and written as compressed chunks to a file of its own inside a
 * private spill directory. A tile is later read back whole, in the order
 * its points were appended, either its coordinates only or its coordinates
 * and records. Memory: one buffer per tile (buffer_bytes) while writing;
 * reading allocates only what the caller asks for.
 *
 * Every point carries: its global index (uint64, increasing within a tile
 * because the tiler appends in input order), x y z (double, frame
 * coordinates), a halo flag (1: the point belongs to a neighbouring tile
 * and is only context here) and its record (record_size bytes, may be 0).
 *
 * Records: the engine creates its spill with record_size 0 (it reads the
 * kept points' records from the inputs instead), but every chunk keeps a
 * record frame and wpd_spill_read can return records: a reader whose
 * inputs cannot be re-read cheaply at a point (a future LAZ reader: points
 * of compressed inputs) may keep their records here. Do not remove them.
 *
 * The library (src/spill/): codec.c encodes the coordinates of a chunk,
 * planes.c the records, store*.c the files, threads and read-back.
 */
#ifndef WPD_SPILL_H
#define WPD_SPILL_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

typedef struct wpd_spill wpd_spill;

/* Full buffers handed to the compression threads are replaced by spares,
 * this many a thread by default: with a few, the appending thread waited for a
 * compression to finish whenever tiles were many and buffers small (100 M
 * points in 292 tiles of 112 KB: tiling 4.6 s with 2 a thread, 3.1 s with
 * 16). */
#define WPD_SPILL_SPARES_PER_THREAD 16

typedef struct wpd_spill_options {
    int level;               /* zstd level (see store.c for the measured choice) */
    size_t buffer_bytes;     /* per-tile write buffer (uncompressed) */
    int threads;             /* compression threads (0: on the appending thread) */
    int spares_per_thread;   /* write buffers handed over per compression thread */
} wpd_spill_options;

/* Fills o with the measured defaults. */
void wpd_spill_default_options(wpd_spill_options *o);

/* Creates ntiles empty tiles in a new private directory under base_dir
 * ("<base_dir>/wpd-spill-<pid>-XXXXXX"). The directory is registered with
 * the process's cleanup (tmpdir.h) so it is removed on exit, on SIGINT and
 * SIGTERM, and by wpd_spill_destroy. Returns NULL with err set (WPD_E_IO). */
wpd_spill *wpd_spill_create(const char *base_dir, int ntiles, uint32_t record_size,
                            const wpd_spill_options *opt, wpd_error *err);

/* Appends n points to tile t. Arrays: gid[n], xyz[3n], halo[n] (NULL: all
 * 0), records[n * record_size]. Compresses and writes the tile's buffer when
 * it fills. Not thread-safe (one tiler thread). Returns 0 or -1 (err set,
 * disk full reported as such). */
int wpd_spill_append(wpd_spill *s, int t, const uint64_t *gid, const double *xyz,
                     const uint8_t *halo, const uint8_t *records, size_t n, wpd_error *err);

/* Writes every tile's remaining buffered points; after it the spill is
 * read-only. Returns 0 or -1. */
int wpd_spill_finish(wpd_spill *s, wpd_error *err);

/* A tile read back: arrays owned by the caller (free with wpd_tile_data_free). */
typedef struct wpd_tile_data {
    size_t n;                /* points (home and halo) */
    uint64_t *gid;           /* [n] */
    double *xyz;             /* [3n] */
    uint8_t *halo;           /* [n] */
    uint8_t *records;        /* [n * record_size], NULL unless asked for */
} wpd_tile_data;

/* Reads tile t whole (after wpd_spill_finish). with_records: also the
 * records. Safe to call from several threads for different (or the same)
 * tiles. Returns 0 or -1 (err set: I/O error, corrupt chunk, out of memory). */
int wpd_spill_read(const wpd_spill *s, int t, int with_records, wpd_tile_data *out,
                   wpd_error *err);

void wpd_tile_data_free(wpd_tile_data *d);

/* Tile t's compressed chunks, as written, in order (after
 * wpd_spill_finish): *out (malloc'd, *len bytes), for wpd_spill_add_chunks
 * into another spill. Returns 0 or -1 (err set). */
int wpd_spill_tile_chunks(const wpd_spill *s, int t, uint8_t **out, size_t *len,
                          wpd_error *err);

/* Appends chunks (wpd_spill_tile_chunks of a spill with the same record
 * size and a chunk no larger than s's) to tile t, after its points so far;
 * t must hold no points still buffered (add chunks to tiles that get no
 * wpd_spill_append, or before it). Not thread-safe with appends to t.
 * Returns 0 or -1 (err set: bytes that are no chunk, I/O errors). */
int wpd_spill_add_chunks(wpd_spill *s, int t, const uint8_t *p, size_t len, wpd_error *err);

/* Points appended to tile t so far. */
uint64_t wpd_spill_count(const wpd_spill *s, int t);

typedef struct wpd_spill_stats {
    uint64_t points;         /* appended over all tiles */
    uint64_t raw_bytes;      /* uncompressed bytes of what was written */
    uint64_t disk_bytes;     /* compressed bytes on disk */
    double compress_seconds, write_seconds;
} wpd_spill_stats;

void wpd_spill_get_stats(const wpd_spill *s, wpd_spill_stats *st);

/* Removes every file and the directory, frees everything. NULL allowed. */
void wpd_spill_destroy(wpd_spill *s);

#endif
