/* runs.h - sorted runs of samples, held in memory or in compressed
 * temporary files, and a k-way merge over them in a bounded budget.
 *
 * A sample is a global index (gid), three coordinates and, when the set
 * carries them, a sharp-feature label (0 or 1). A run is a sequence of
 * samples with strictly ascending gids; a set holds runs numbered 0, 1,
 * ... (a run may be empty). A set is either
 *   in memory  every run's arrays held as given (no copy when taken), or
 *   in files   every run one file "run-<id>" in a private directory
 *              "wpd-runs-<pid>-XXXXXX" (common/tmpdir.h: removed on every
 *              exit path, on SIGINT/SIGTERM/SIGHUP, and by a later run's
 *              sweep when the process was killed), written as chunks of at
 *              most chunk_points samples, each the spill's coordinate codec
 *              (codec.h: gids as differences, coordinates on their decimal
 *              grid or raw, labels as bits) in a zstd frame with checksum.
 *              The chunk index stays in memory (24 bytes a chunk).
 * A run is written whole (wpd_runs_put), appended to (wpd_runs_append),
 * read whole (wpd_runs_read) or chunk by chunk through a reader with one
 * chunk's buffer (wpd_run_reader), and cleared. So a set serves as a
 * per-tile sample store (run t: tile t's samples) as well as the runs of
 * a merge.
 *
 * Threads: calls on different runs may run on different threads once the
 * runs exist (wpd_runs_reserve or wpd_runs_add beforehand, on one thread);
 * readers share nothing but the read-only index. Errors: WPD_E_IO naming
 * the file, WPD_E_MEMORY, WPD_E_INPUT for a damaged chunk.
 */
#ifndef WPD_SPILL_RUNS_H
#define WPD_SPILL_RUNS_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

/* Default samples a chunk of a file run holds at most. */
#define WPD_RUNS_CHUNK_POINTS 8192

/* Bytes one sample takes decoded: gid, x y z, label. */
#define WPD_RUNS_SAMPLE_BYTES (sizeof(uint64_t) + 3 * sizeof(double) + 1)

/* Samples to read: valid until the call that gave them is repeated. */
typedef struct wpd_sample_view {
    size_t n;
    const uint64_t *gid;      /* [n] ascending */
    const double *xyz;        /* [3n] */
    const uint8_t *edge;      /* [n] labels, or NULL: none (all 0) */
} wpd_sample_view;

typedef struct wpd_runs wpd_runs;

typedef struct wpd_runs_options {
    const char *dir;          /* base of the private directory; NULL: in memory */
    int with_edge;            /* 1: samples carry labels */
    size_t chunk_points;      /* 0: WPD_RUNS_CHUNK_POINTS */
    int level;                /* zstd level of file chunks (0: -3, as the spill) */
} wpd_runs_options;

/* An empty set (in files: its directory created). Returns 0 with *out
 * set, or -1 with err set. */
int wpd_runs_open(const wpd_runs_options *o, wpd_runs **out, wpd_error *err);
/* Frees the set; in files, removes every file and the directory. NULL ok. */
void wpd_runs_close(wpd_runs *rs);

int wpd_runs_count(const wpd_runs *rs);           /* runs: ids 0 .. count-1 */
uint64_t wpd_runs_length(const wpd_runs *rs, int id);
int wpd_runs_in_files(const wpd_runs *rs);
int wpd_runs_with_edge(const wpd_runs *rs);
size_t wpd_runs_chunk_points(const wpd_runs *rs);
/* Bytes the set holds in memory (memory runs' arrays and the index). */
size_t wpd_runs_memory_bytes(const wpd_runs *rs);
/* Compressed bytes of the file runs (0 in memory). */
uint64_t wpd_runs_disk_bytes(const wpd_runs *rs);

/* Makes runs 0 .. n-1 exist (new ones empty). Returns 0 or -1 (memory). */
int wpd_runs_reserve(wpd_runs *rs, int n, wpd_error *err);
/* A new empty run; its id in *id. Returns 0 or -1. */
int wpd_runs_add(wpd_runs *rs, int *id, wpd_error *err);

/* Appends v's samples to run id; their gids must ascend strictly and lie
 * above the run's last (else WPD_E_INPUT). Memory: copied. Files: written
 * in chunks of at most chunk_points. A label above 1 is stored as 1.
 * Returns 0, or -1 with err set (the run is then undefined: clear it). */
int wpd_runs_append(wpd_runs *rs, int id, const wpd_sample_view *v, wpd_error *err);

/* Replaces run id by n samples in malloc'd arrays (edge may be NULL),
 * which the set takes in every case: kept as they are in memory, written
 * and freed in files. Returns 0, or -1 with err set (run id then empty). */
int wpd_runs_put(wpd_runs *rs, int id, uint64_t *gid, double *xyz, uint8_t *edge, size_t n,
                 wpd_error *err);

/* Empties run id (its file removed). */
void wpd_runs_clear(wpd_runs *rs, int id);

/* Run id whole, into malloc'd arrays (*edge NULL when the set has no
 * labels). Returns 0 or -1 with err set (nothing allocated). */
int wpd_runs_read(const wpd_runs *rs, int id, uint64_t **gid, double **xyz, uint8_t **edge,
                  size_t *n, wpd_error *err);

/* ------------------------------------------------------ sequential reading */

/* Scratch to decode file chunks: one per thread, shared by its readers
 * (one chunk is decoded at a time). */
typedef struct wpd_run_decoder wpd_run_decoder;
wpd_run_decoder *wpd_run_decoder_new(const wpd_runs *rs);
void wpd_run_decoder_free(wpd_run_decoder *d);
/* Bytes of a decoder for chunks of chunk_points samples. */
size_t wpd_run_decoder_bytes(size_t chunk_points);

typedef struct wpd_run_reader {
    const wpd_runs *rs;
    int id;
    uint64_t done;            /* samples handed out so far */
    uint32_t chunk;           /* next chunk (files) */
    int fd;                   /* the run's file once read from, else -1 */
    uint64_t *gid;            /* one chunk, decoded (files) */
    double *xyz;
    uint8_t *edge;
} wpd_run_reader;

/* Starts reading run id from its first sample. */
void wpd_run_reader_open(wpd_run_reader *r, const wpd_runs *rs, int id);
/* The next chunk of at most chunk_points samples into *v (v->n == 0 at the
 * end of the run), decoded with d (files). Returns 0, or -1 with err. */
int wpd_run_reader_next(wpd_run_reader *r, wpd_run_decoder *d, wpd_sample_view *v,
                        wpd_error *err);
void wpd_run_reader_close(wpd_run_reader *r);

#endif
