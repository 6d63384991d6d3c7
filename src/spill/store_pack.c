/* store_pack.c - compression of full write buffers into chunks and their
 * writing (see store.h).
 *
 * A chunk holds one write buffer: the chunk header, the coordinate frame
 * (the block of codec.h, zstd with checksum) and the record frame (the
 * records as byte planes, planes.h, zstd with checksum; empty for
 * record_size 0). With options.threads k > 0, k threads take full buffers
 * from a queue; with 0 the appending thread compresses itself. A thread
 * needs about 2.5 buffer_bytes of scratch and a zstd context.
 */
#include "common/fullio.h"
#include "spill/store.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <zstd_errors.h>

#include "spill/codec.h"
#include "spill/planes.h"

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* Largest chunk: the header and both frames at zstd's worst case. */
static size_t chunk_bound(const wpd_spill *s)
{
    return sizeof(chunk_head) + ZSTD_compressBound(wpd_coords_bound(s->cap)) +
           ZSTD_compressBound(rec_bytes(s, s->cap));
}

void spill_packer_free(packer *c)
{
    ZSTD_freeCCtx(c->cctx);
    free(c->raw);
    free(c->out);
    free(c->scratch);
    memset(c, 0, sizeof *c);
}

/* Scratch and a zstd context for one compressing thread (cap points a
 * chunk). Returns 0, or -1 with nothing allocated. */
int spill_packer_init(const wpd_spill *s, packer *c)
{
    size_t raw = wpd_coords_bound(s->cap);
    if (rec_bytes(s, s->cap) > raw)
        raw = rec_bytes(s, s->cap);
    c->cctx = ZSTD_createCCtx();
    c->raw = malloc(raw);
    c->out = malloc(chunk_bound(s));
    c->scratch = malloc(2 * s->cap * sizeof *c->scratch);
    if (!c->cctx || !c->raw || !c->out || !c->scratch ||
        ZSTD_isError(ZSTD_CCtx_setParameter(c->cctx, ZSTD_c_compressionLevel, s->opt.level)) ||
        ZSTD_isError(ZSTD_CCtx_setParameter(c->cctx, ZSTD_c_checksumFlag, 1))) {
        spill_packer_free(c);
        return -1;
    }
    return 0;
}

/* Appends a compressed chunk to its tile's file and enters it in the
 * index at its sequence number. The file range is reserved under the lock;
 * the write itself runs without it (page-cache writes can take long). */
static void write_chunk(wpd_spill *s, const job *j, const uint8_t *data, const chunk_ref *ref)
{
    tile *T = &s->tiles[j->tile];
    size_t len = sizeof(chunk_head) + ref->coord_z + ref->rec_z;
    pthread_mutex_lock(&s->mu);
    if (s->failed) {
        pthread_mutex_unlock(&s->mu);
        return;
    }
    int slot, fd = spill_tile_fd_locked(s, j->tile, &slot);
    uint64_t off = T->file_size;
    T->file_size += len;
    pthread_mutex_unlock(&s->mu);

    double t0 = now_seconds();
    int failed = fd < 0 || wpd_pwrite_full(fd, data, len, off);
    int saved = errno;
    double t1 = now_seconds();

    pthread_mutex_lock(&s->mu);
    if (slot >= 0)
        s->open_files[slot].pins--;
    else if (fd >= 0)
        spill_close_tile_fd_locked(s, fd, j->tile);
    if (failed) {
        wpd_error e;
        char path[1100];
        spill_tile_path(s, j->tile, path, sizeof path);
        errno = saved;
        wpd_fail_errno(&e, "%s: cannot %s spill file", path, fd < 0 ? "create" : "write");
        spill_set_failed_locked(s, &e);
    } else {
        T->chunks[j->seq] = *ref;
        T->chunks[j->seq].off = off;
        s->stats.write_seconds += t1 - t0;
        s->stats.disk_bytes += len;
        s->stats.raw_bytes += j->n * (33 + (uint64_t)s->rs);
    }
    pthread_mutex_unlock(&s->mu);
}

/* Compresses the job's points with packer c and writes them. */
void spill_run_job(wpd_spill *s, packer *c, const job *j)
{
    if (__atomic_load_n(&s->failed, __ATOMIC_ACQUIRE))
        return;
    double t0 = now_seconds();
    const wbuf *b = j->buf;
    size_t craw = wpd_coords_encode(b->gid, b->xyz, b->halo, j->n, c->raw, c->scratch);
    uint8_t *p = c->out + sizeof(chunk_head);
    size_t cap = chunk_bound(s) - sizeof(chunk_head);
    size_t cz = ZSTD_compress2(c->cctx, p, cap, c->raw, craw);
    size_t rz = 0;
    if (!ZSTD_isError(cz) && s->rs) {
        wpd_planes_from_records(c->raw, b->rec, j->n, s->rs);
        rz = ZSTD_compress2(c->cctx, p + cz, cap - cz, c->raw, rec_bytes(s, j->n));
    }
    double t1 = now_seconds();
    chunk_head h = {CHUNK_MAGIC, (uint32_t)j->tile, j->seq, (uint32_t)j->n,
                    (uint32_t)craw, (uint32_t)cz, (uint32_t)rz, 0};
    memcpy(c->out, &h, sizeof h);
    chunk_ref ref = {0, h.n, h.coord_raw, h.coord_z, h.rec_z};
    pthread_mutex_lock(&s->mu);
    s->stats.compress_seconds += t1 - t0;
    if (ZSTD_isError(cz) || ZSTD_isError(rz)) {
        wpd_error e;
        size_t why = ZSTD_isError(cz) ? cz : rz;
        /* zstd allocates its workspace on the first compression. */
        wpd_fail(&e, ZSTD_getErrorCode(why) == ZSTD_error_memory_allocation ? WPD_E_MEMORY
                                                                           : WPD_E_IO,
                 "%s: zstd compression failed: %s", s->dir, ZSTD_getErrorName(why));
        spill_set_failed_locked(s, &e);
    }
    pthread_mutex_unlock(&s->mu);
    if (!ZSTD_isError(cz) && !ZSTD_isError(rz))
        write_chunk(s, j, c->out, &ref);
}

void *spill_worker_main(void *arg)
{
    wpd_spill *s = arg;
    packer c;
    int ok = spill_packer_init(s, &c) == 0;
    pthread_mutex_lock(&s->mu);
    if (!ok) {
        wpd_error e;
        wpd_fail(&e, WPD_E_MEMORY, "%s: out of memory for a spill compression thread", s->dir);
        spill_set_failed_locked(s, &e);
    }
    for (;;) {
        while (!s->qlen && !s->stop)
            pthread_cond_wait(&s->cv_job, &s->mu);
        if (!s->qlen)
            break;
        job j = s->queue[s->qhead];
        s->qhead = (s->qhead + 1) % s->qcap;
        s->qlen--;
        pthread_mutex_unlock(&s->mu);
        if (ok)
            spill_run_job(s, &c, &j);
        pthread_mutex_lock(&s->mu);
        j.buf->next = s->free_list;
        s->free_list = j.buf;
        s->in_flight--;
        pthread_cond_signal(&s->cv_free);
        if (!s->in_flight)
            pthread_cond_broadcast(&s->cv_idle);
    }
    pthread_mutex_unlock(&s->mu);
    if (ok)
        spill_packer_free(&c);
    return NULL;
}

/* Stops the compression threads after the queued jobs. */
void spill_stop_workers(wpd_spill *s)
{
    pthread_mutex_lock(&s->mu);
    s->stop = 1;
    pthread_cond_broadcast(&s->cv_job);
    pthread_mutex_unlock(&s->mu);
    for (int k = 0; k < s->nworkers; k++)
        pthread_join(s->workers[k], NULL);
    s->nworkers = 0;
}
