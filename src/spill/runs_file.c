/* runs_file.c - file runs (runs.h): chunks encoded with the spill's
 * coordinate codec and compressed, appended to the run's file, and read
 * back one at a time against the in-memory index.
 *
 * A chunk is one zstd frame (with checksum) around one codec block; the
 * index holds its offset, sizes and count, so a short, damaged or foreign
 * chunk is an error naming the file. The codec's halo bits carry the
 * labels (0 or 1); without labels they are all 0 and take no bytes.
 */
#include "spill/runs_impl.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/fullio.h"
#include "spill/codec.h"

void runs_file_path(const wpd_runs *rs, int id, char *out, size_t len)
{
    snprintf(out, len, "%s/run-%06d", rs->dir, id);
}

void runs_encoder_free(run_encoder *e)
{
    free(e->raw);
    free(e->zbuf);
    free(e->zeros);
    free(e->scratch);
    ZSTD_freeCCtx(e->cctx);
    memset(e, 0, sizeof *e);
}

/* Sizes e for chunks of cap samples at the set's level. Returns 0 or -1. */
static int encoder_init(run_encoder *e, const wpd_runs *rs, size_t cap)
{
    memset(e, 0, sizeof *e);
    e->cap = cap;
    e->raw = malloc(wpd_coords_bound(cap));
    e->zbuf = malloc(ZSTD_compressBound(wpd_coords_bound(cap)));
    e->zeros = calloc(cap, 1);
    e->scratch = malloc(2 * cap * sizeof *e->scratch);
    e->cctx = ZSTD_createCCtx();
    if (!e->raw || !e->zbuf || !e->zeros || !e->scratch || !e->cctx ||
        ZSTD_isError(ZSTD_CCtx_setParameter(e->cctx, ZSTD_c_compressionLevel, rs->level)) ||
        ZSTD_isError(ZSTD_CCtx_setParameter(e->cctx, ZSTD_c_checksumFlag, 1))) {
        runs_encoder_free(e);
        return -1;
    }
    return 0;
}

/* The set's encoder when free (*own 0), else a new one (*own 1). */
static run_encoder *take_encoder(wpd_runs *rs, run_encoder *local, int *own)
{
    *own = __atomic_exchange_n(&rs->encoder_busy, 1, __ATOMIC_ACQUIRE) != 0;
    run_encoder *e = *own ? local : &rs->encoder;
    if (e->cctx || encoder_init(e, rs, rs->chunk_points) == 0)
        return e;
    if (!*own)
        __atomic_store_n(&rs->encoder_busy, 0, __ATOMIC_RELEASE);
    return NULL;
}

static void give_encoder(wpd_runs *rs, run_encoder *e, int own)
{
    if (own)
        runs_encoder_free(e);
    else
        __atomic_store_n(&rs->encoder_busy, 0, __ATOMIC_RELEASE);
}

/* Room for one more chunk in r's index. */
static int grow_index(run *r)
{
    if (r->nchunks < r->chunks_cap)
        return 0;
    uint32_t cap = r->chunks_cap ? 2 * r->chunks_cap : 8;
    run_chunk *c = realloc(r->chunks, cap * sizeof *c);
    if (!c)
        return -1;
    r->chunks = c;
    r->chunks_cap = cap;
    return 0;
}

/* Encodes, compresses and writes samples [from, from + m) of v as the next
 * chunk of run id through fd. */
static int write_chunk(wpd_runs *rs, int id, int fd, run_encoder *e, const wpd_sample_view *v,
                       size_t from, size_t m, wpd_error *err)
{
    run *r = &rs->runs[id];
    char path[1100];
    const uint8_t *labels = v->edge && rs->with_edge ? v->edge + from : e->zeros;
    size_t raw = wpd_coords_encode(v->gid + from, v->xyz + 3 * from, labels, m, e->raw,
                                   e->scratch);
    size_t z = ZSTD_compress2(e->cctx, e->zbuf, ZSTD_compressBound(wpd_coords_bound(e->cap)),
                              e->raw, raw);
    if (ZSTD_isError(z))
        return wpd_fail(err, WPD_E_MEMORY, "%s: cannot compress a run chunk: %s", rs->dir,
                        ZSTD_getErrorName(z));
    if (grow_index(r))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the index of %s", rs->dir);
    if (wpd_pwrite_full(fd, e->zbuf, z, r->bytes)) {
        runs_file_path(rs, id, path, sizeof path);
        return wpd_fail_errno(err, "%s: cannot write run file", path);
    }
    r->chunks[r->nchunks++] = (run_chunk){r->bytes, (uint32_t)z, (uint32_t)raw, (uint32_t)m};
    r->bytes += z;
    return 0;
}

int runs_file_append(wpd_runs *rs, int id, const wpd_sample_view *v, wpd_error *err)
{
    char path[1100];
    runs_file_path(rs, id, path, sizeof path);
    int fd = open(path, O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
    if (fd < 0)
        return wpd_fail_errno(err, "%s: cannot create run file", path);
    run_encoder local = {0};
    int own, rc = 0;
    run_encoder *e = take_encoder(rs, &local, &own);
    if (!e)
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory to write %s", path);
    for (size_t from = 0; rc == 0 && from < v->n; from += rs->chunk_points) {
        size_t m = v->n - from < rs->chunk_points ? v->n - from : rs->chunk_points;
        rc = write_chunk(rs, id, fd, e, v, from, m, err);
    }
    if (e)
        give_encoder(rs, e, own);
    /* Storage that reports a lost write only at close (NFS, quotas). */
    if (close(fd) && rc == 0)
        rc = wpd_fail_errno(err, "%s: cannot close run file", path);
    return rc;
}

int runs_file_open(const wpd_runs *rs, int id, wpd_error *err)
{
    char path[1100];
    runs_file_path(rs, id, path, sizeof path);
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        wpd_fail_errno(err, "%s: cannot open run file", path);
    return fd;
}

/* A failure reading chunk c of run id, naming the file. */
static int chunk_error(const wpd_runs *rs, int id, uint32_t c, const char *what,
                       wpd_error *err)
{
    char path[1100];
    runs_file_path(rs, id, path, sizeof path);
    return wpd_fail(err, WPD_E_INPUT, "%s: chunk %u: %s", path, c, what);
}

int runs_file_read_chunk(const wpd_runs *rs, int id, int fd, uint32_t c, wpd_run_decoder *d,
                         uint64_t *gid, double *xyz, uint8_t *edge, wpd_error *err)
{
    const run_chunk *k = &rs->runs[id].chunks[c];
    if (k->count > d->chunk_points || k->raw_bytes > wpd_coords_bound(d->chunk_points) ||
        k->zbytes > ZSTD_compressBound(wpd_coords_bound(d->chunk_points)))
        return chunk_error(rs, id, c, "larger than a chunk", err);
    ssize_t got = wpd_pread_full(fd, d->zbuf, k->zbytes, k->offset);
    if (got < 0) {
        char path[1100];
        runs_file_path(rs, id, path, sizeof path);
        return wpd_fail_errno(err, "%s: cannot read run file", path);
    }
    if ((size_t)got != k->zbytes)
        return chunk_error(rs, id, c, "file ends early", err);
    size_t raw = ZSTD_decompressDCtx(d->dctx, d->raw, k->raw_bytes, d->zbuf, k->zbytes);
    if (ZSTD_isError(raw) || raw != k->raw_bytes)
        return chunk_error(rs, id, c, "damaged (zstd)", err);
    uint8_t *labels = edge ? edge : d->halo;
    wpd_error why;
    if (wpd_coords_decode(d->raw, raw, k->count, gid, xyz, labels, d->scratch, &why))
        return chunk_error(rs, id, c, why.msg, err);
    return 0;
}

size_t wpd_run_decoder_bytes(size_t chunk_points)
{
    return ZSTD_compressBound(wpd_coords_bound(chunk_points)) + wpd_coords_bound(chunk_points) +
           chunk_points * (1 + 2 * sizeof(uint64_t)) + RUNS_DCTX_BYTES;
}

wpd_run_decoder *wpd_run_decoder_new(const wpd_runs *rs)
{
    size_t cap = rs->chunk_points;
    wpd_run_decoder *d = calloc(1, sizeof *d);
    if (!d)
        return NULL;
    d->chunk_points = cap;
    d->zbuf = malloc(ZSTD_compressBound(wpd_coords_bound(cap)));
    d->raw = malloc(wpd_coords_bound(cap));
    d->halo = malloc(cap);
    d->scratch = malloc(2 * cap * sizeof *d->scratch);
    d->dctx = ZSTD_createDCtx();
    if (!d->zbuf || !d->raw || !d->halo || !d->scratch || !d->dctx) {
        wpd_run_decoder_free(d);
        return NULL;
    }
    return d;
}

void wpd_run_decoder_free(wpd_run_decoder *d)
{
    if (!d)
        return;
    free(d->zbuf);
    free(d->raw);
    free(d->halo);
    free(d->scratch);
    ZSTD_freeDCtx(d->dctx);
    free(d);
}
