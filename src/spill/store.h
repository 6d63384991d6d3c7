/* store.h - internals shared by the spill store's files (not an API):
 *   store.c        creation, appending, finishing, statistics, teardown
 *   store_pack.c   compression of full buffers (threads) and chunk writes
 *   store_files.c  the tile files: paths, the descriptor cache, I/O
 *   store_read.c   reading a tile back
 */
#ifndef WPD_SPILL_STORE_H
#define WPD_SPILL_STORE_H

#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <zstd.h>

#include "spill/spill.h"

#define CHUNK_MAGIC 0x31505357u  /* "WSP1" little-endian */
#define MAX_OPEN_FILES 64        /* tile files kept open while writing */

/* On disk a chunk is this header, the coordinate frame (coord_z bytes,
 * zstd with checksum) and the record frame (rec_z bytes). The header
 * repeats the in-memory index so that a damaged file is recognised. */
typedef struct chunk_head {
    uint32_t magic, tile, seq, n;
    uint32_t coord_raw, coord_z, rec_z, pad;
} chunk_head;

typedef struct chunk_ref {
    uint64_t off;
    uint32_t n, coord_raw, coord_z, rec_z;
} chunk_ref;

/* Write buffer of one tile: columns for cap points in one allocation. */
typedef struct wbuf {
    uint64_t *gid;
    double *xyz;
    uint8_t *rec;
    uint8_t *halo;
    struct wbuf *next; /* free list */
} wbuf;

typedef struct tile {
    wbuf *buf;             /* NULL until the first append */
    size_t fill;           /* points in buf */
    uint64_t count;        /* points appended */
    chunk_ref *chunks;     /* [nchunks], in append order */
    uint32_t nchunks, chunks_cap;
    uint64_t file_size;
    int fd_slot;           /* index into open_files, or -1 */
} tile;

/* Scratch of one compressing thread. */
typedef struct packer {
    ZSTD_CCtx *cctx;
    uint8_t *raw;          /* coordinate block, then record planes */
    uint8_t *out;          /* chunk as written */
    uint64_t *scratch;     /* 2 cap values for the codec */
} packer;

typedef struct job {
    int tile;
    uint32_t seq;
    size_t n;
    wbuf *buf;
} job;

struct wpd_spill {
    char dir[1024];
    int ntiles;
    uint32_t rs;
    wpd_spill_options opt;
    size_t cap;            /* points per chunk */
    tile *tiles;
    int finished;

    pthread_mutex_t mu;    /* everything below */
    pthread_cond_t cv_job, cv_free, cv_idle;
    pthread_t *workers;
    int nworkers, stop;
    job *queue;            /* ring of qcap jobs */
    size_t qhead, qlen, qcap;
    wbuf *free_list;
    int spares, max_spares, in_flight;
    packer sync_packer;    /* compression on the caller's thread */
    struct { int tile, fd, pins; uint64_t used; } open_files[MAX_OPEN_FILES];
    uint64_t clock;
    int failed;            /* read without the lock through __atomic */
    wpd_error error;       /* the first failure */
    wpd_spill_stats stats;
};

static inline size_t rec_bytes(const wpd_spill *s, size_t n)
{
    return n * s->rs;
}

/* store.c */
void spill_set_failed_locked(wpd_spill *s, const wpd_error *e);
int spill_report_failure(const wpd_spill *s, wpd_error *err);

/* store_pack.c */
int spill_packer_init(const wpd_spill *s, packer *c);
void spill_packer_free(packer *c);
void spill_run_job(wpd_spill *s, packer *c, const job *j);
void *spill_worker_main(void *arg);
void spill_stop_workers(wpd_spill *s);

/* store_files.c */
void spill_tile_path(const wpd_spill *s, int t, char *out, size_t len);
int spill_tile_fd_locked(wpd_spill *s, int t, int *slot_out);
void spill_close_tile_fd_locked(wpd_spill *s, int fd, int t);
void spill_close_files(wpd_spill *s);

#endif
