/* runs_impl.h - the runs' internals (runs.h), shared by runs.c (the set,
 * memory runs, readers) and runs_file.c (file runs) and by nothing else. */
#ifndef WPD_SPILL_RUNS_IMPL_H
#define WPD_SPILL_RUNS_IMPL_H

#include <zstd.h>

#include "spill/runs.h"

/* Upper bounds of a zstd context's own memory for chunks of up to a few MB
 * at the set's low levels (ZSTD_estimate* are not in the stable API). */
#define RUNS_CCTX_BYTES ((size_t)1 << 20)
#define RUNS_DCTX_BYTES ((size_t)256 << 10)

/* One chunk of a file run. */
typedef struct run_chunk {
    uint64_t offset;          /* in the run's file */
    uint32_t zbytes;          /* the zstd frame */
    uint32_t raw_bytes;       /* the codec block inside it */
    uint32_t count;           /* samples */
} run_chunk;

typedef struct run {
    uint64_t n;
    uint64_t last;            /* gid of the last sample (when n > 0) */
    /* memory */
    uint64_t *gid;
    double *xyz;
    uint8_t *edge;            /* or NULL: all 0 */
    size_t cap;
    /* files */
    run_chunk *chunks;
    uint32_t nchunks, chunks_cap;
    uint64_t bytes;           /* file size */
} run;

/* What writing a chunk needs; the set keeps one for whichever append
 * takes it first (encoder_busy), others make their own. */
typedef struct run_encoder {
    size_t cap;               /* samples */
    uint8_t *raw, *zbuf, *zeros;
    uint64_t *scratch;
    ZSTD_CCtx *cctx;
} run_encoder;

struct wpd_runs {
    int in_files, with_edge;
    run_encoder encoder;
    int encoder_busy;         /* atomic */
    size_t chunk_points;
    int level;
    char dir[1024];
    run *runs;
    int nruns, cap;
};

struct wpd_run_decoder {
    size_t chunk_points;
    uint8_t *zbuf, *raw, *halo;
    uint64_t *scratch;        /* 2 chunk_points: the codec's */
    ZSTD_DCtx *dctx;
};

/* Path of run id's file. */
void runs_file_path(const wpd_runs *rs, int id, char *out, size_t len);

/* Appends v (checked by the caller) to file run r (id) in chunks. */
int runs_file_append(wpd_runs *rs, int id, const wpd_sample_view *v, wpd_error *err);

/* Opens run id's file for reading: a descriptor, or -1 with err set. */
int runs_file_open(const wpd_runs *rs, int id, wpd_error *err);

/* Decodes chunk c of run id (file descriptor fd) into gid/xyz/edge (edge
 * may be NULL: labels not wanted). Returns 0 or -1 with err set. */
int runs_file_read_chunk(const wpd_runs *rs, int id, int fd, uint32_t c, wpd_run_decoder *d,
                         uint64_t *gid, double *xyz, uint8_t *edge, wpd_error *err);

void runs_encoder_free(run_encoder *e);

#endif
