/* store.c - per-tile spill files (see spill.h): creating the spill,
 * appending, finishing, statistics, teardown. The other concerns live
 * beside it (store.h lists them); the codec of a chunk's coordinates is
 * codec.c, of its records planes.c.
 *
 * Files: "<dir>/tile-NNNNNN", one per tile that received points, a
 * sequence of chunks; a chunk holds one full write buffer (or the tail at
 * wpd_spill_finish): a 32-byte header, then the coordinate frame (gid, xyz,
 * halo; codec.h, zstd with checksum), then the record frame (the records
 * as byte planes, zstd with checksum). A coordinate read reads headers and
 * coordinate frames only. The chunk index stays in memory; each header
 * repeats it, so damage is an error naming the file.
 *
 * Threads (options.threads): 0 compresses and writes on the appending
 * thread; k > 0 starts k compression threads: a full buffer is handed over
 * and the tile continues in a spare one (options.spares_per_thread a
 * thread). Memory while writing: (tiles that received points +
 * spares_per_thread k) * buffer_bytes, plus per thread about 2.5
 * buffer_bytes of scratch and a zstd context. Halo flags are stored as
 * bits: any nonzero flag reads back as 1.
 *
 * Level -3 by default (bench/spill.sh; figures in codec.c and planes.c):
 * against -7, 6-15 % smaller for 1-12 % more compression time; levels >= 1
 * cost 20-40 % more time for a few %.
 *
 * End to end, 100 M points into 256 tiles, defaults (level -3, 256 KB
 * buffers, 2 compression threads beside the appending thread, 2 cores),
 * bench/spill.sh:
 *                           tiling wall  in append  disk   ratio  coords  +records
 *   synthetic 20 M x 5        4.1 s       2.9 s    1052 MB  6.37  1.0 s    1.9 s
 *   NC Raleigh x 44           4.8 s       3.4 s    1372 MB  5.17  1.1 s    2.3 s
 * (tiling wall includes reading the LAS input; coords / +records: one
 * read-back of every tile on 2 threads). Writing to the page cache costs
 * 0.5 - 2.7 ns a byte of kernel time on this VM, so the ratio matters even
 * when nothing reaches the disk.
 */
#include "spill/store.h"

#include <stdlib.h>
#include <string.h>
#include <zstd.h>

#include "common/tmpdir.h"

/* Records the first failure (caller holds the lock). */
void spill_set_failed_locked(wpd_spill *s, const wpd_error *e)
{
    if (!s->failed) {
        s->error = *e;
        __atomic_store_n(&s->failed, 1, __ATOMIC_RELEASE);
    }
}

int spill_report_failure(const wpd_spill *s, wpd_error *err)
{
    if (err)
        *err = s->error;
    return -1;
}

static wbuf *wbuf_new(const wpd_spill *s)
{
    size_t cap = s->cap;
    wbuf *b = malloc(sizeof *b + cap * (8 + 24 + 1) + rec_bytes(s, cap));
    if (!b)
        return NULL;
    b->gid = (uint64_t *)(b + 1);
    b->xyz = (double *)(b->gid + cap);
    b->rec = (uint8_t *)(b->xyz + 3 * cap);
    b->halo = b->rec + rec_bytes(s, cap);
    b->next = NULL;
    return b;
}


/* Reserves the next chunk number of tile t. Lock held. */
static int reserve_chunk_locked(wpd_spill *s, int t, uint32_t *seq)
{
    tile *T = &s->tiles[t];
    if (T->nchunks == T->chunks_cap) {
        uint32_t cap = T->chunks_cap ? 2 * T->chunks_cap : 16;
        chunk_ref *c = realloc(T->chunks, cap * sizeof *c);
        if (!c)
            return -1;
        T->chunks = c;
        T->chunks_cap = cap;
    }
    *seq = T->nchunks++;
    return 0;
}

/* Hands tile t's buffered points to compression. With compression
 * threads the tile gets a free buffer back (refill: 1) or none (at the
 * end); on the caller's thread the buffer is kept. Returns 0 or -1. */
static int submit(wpd_spill *s, int t, int refill, wpd_error *err)
{
    tile *T = &s->tiles[t];
    job j = {t, 0, T->fill, T->buf};
    pthread_mutex_lock(&s->mu);
    if (reserve_chunk_locked(s, t, &j.seq)) {
        pthread_mutex_unlock(&s->mu);
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the spill index", s->dir);
    }
    if (!s->nworkers) {
        pthread_mutex_unlock(&s->mu);
        spill_run_job(s, &s->sync_packer, &j);
        T->fill = 0;
        return s->failed ? spill_report_failure(s, err) : 0;
    }
    s->queue[(s->qhead + s->qlen++) % s->qcap] = j;
    s->in_flight++;
    pthread_cond_signal(&s->cv_job);
    T->buf = NULL;
    T->fill = 0;
    while (refill && !T->buf) {
        if (s->free_list) {
            T->buf = s->free_list;
            s->free_list = T->buf->next;
        } else if (s->spares < s->max_spares) {
            s->spares++;
            pthread_mutex_unlock(&s->mu);
            T->buf = wbuf_new(s);
            pthread_mutex_lock(&s->mu);
            if (!T->buf) {
                pthread_mutex_unlock(&s->mu);
                return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for spill buffers", s->dir);
            }
        } else {
            pthread_cond_wait(&s->cv_free, &s->mu);
        }
    }
    int failed = s->failed;
    pthread_mutex_unlock(&s->mu);
    return failed ? spill_report_failure(s, err) : 0;
}

/* Frees every write buffer and scratch, closes the files. */
static void release_writing(wpd_spill *s)
{
    for (int t = 0; t < s->ntiles; t++) {
        free(s->tiles[t].buf);
        s->tiles[t].buf = NULL;
    }
    while (s->free_list) {
        wbuf *b = s->free_list;
        s->free_list = b->next;
        free(b);
    }
    spill_close_files(s);
    spill_packer_free(&s->sync_packer);
    free(s->queue);
    s->queue = NULL;
}

void wpd_spill_default_options(wpd_spill_options *o)
{
    o->level = -3;
    o->buffer_bytes = 256 << 10;
    o->threads = 2;
    o->spares_per_thread = WPD_SPILL_SPARES_PER_THREAD;
}

/* Options (clamped), chunk capacity and the initial state of a new spill. */
static void configure(wpd_spill *s, int ntiles, uint32_t record_size,
                      const wpd_spill_options *opt)
{
    if (opt)
        s->opt = *opt;
    else
        wpd_spill_default_options(&s->opt);
    if (s->opt.level < ZSTD_minCLevel())
        s->opt.level = ZSTD_minCLevel();
    if (s->opt.level > ZSTD_maxCLevel())
        s->opt.level = ZSTD_maxCLevel();
    s->ntiles = ntiles;
    s->rs = record_size;
    /* Chunk sizes are stored in 32 bits: keep a chunk well below 2^31. */
    size_t per_point = 33 + record_size, bytes = s->opt.buffer_bytes;
    bytes = bytes < (4u << 10) ? (4u << 10) : bytes > (256u << 20) ? (256u << 20) : bytes;
    s->cap = bytes / per_point ? bytes / per_point : 1;
    for (int t = 0; t < ntiles; t++)
        s->tiles[t].fd_slot = -1;
    for (int k = 0; k < MAX_OPEN_FILES; k++)
        s->open_files[k].fd = -1;
    pthread_mutex_init(&s->mu, NULL);
    pthread_cond_init(&s->cv_job, NULL);
    pthread_cond_init(&s->cv_free, NULL);
    pthread_cond_init(&s->cv_idle, NULL);
}

/* Starts the compression threads the options ask for (at most 64); as
 * many as start are used (0: compression on the appending thread). */
static void start_workers(wpd_spill *s)
{
    int want = s->opt.threads < 0 ? 0 : s->opt.threads > 64 ? 64 : s->opt.threads;
    if (!want)
        return;
    int spares = s->opt.spares_per_thread < 1 ? 1 : s->opt.spares_per_thread;
    /* Room for every tile's buffer and every spare: a push never waits. */
    s->qcap = (size_t)s->ntiles + (size_t)want * (size_t)spares + 1;
    s->queue = malloc(s->qcap * sizeof *s->queue);
    s->workers = malloc((size_t)want * sizeof *s->workers);
    s->max_spares = want * spares;
    for (int k = 0; s->queue && s->workers && k < want; k++)
        if (pthread_create(&s->workers[k], NULL, spill_worker_main, s) == 0)
            s->nworkers++;
}

wpd_spill *wpd_spill_create(const char *base_dir, int ntiles, uint32_t record_size,
                            const wpd_spill_options *opt, wpd_error *err)
{
    if (ntiles < 1 || ntiles > (1 << 22) || record_size > (1u << 20)) {
        wpd_fail(err, WPD_E_USAGE, "%s: cannot spill %d tiles of %u-byte records", base_dir,
                 ntiles, record_size);
        return NULL;
    }
    wpd_spill *s = calloc(1, sizeof *s);
    if (!s || !(s->tiles = calloc((size_t)ntiles, sizeof *s->tiles))) {
        free(s);
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for %d spill tiles", base_dir, ntiles);
        return NULL;
    }
    configure(s, ntiles, record_size, opt);
    if (wpd_tmpdir_create(base_dir, "wpd-spill", s->dir, sizeof s->dir, err)) {
        s->dir[0] = '\0';
        wpd_spill_destroy(s);
        return NULL;
    }
    start_workers(s);
    if (!s->nworkers && spill_packer_init(s, &s->sync_packer)) {
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for spill compression", s->dir);
        wpd_spill_destroy(s);
        return NULL;
    }
    return s;
}

int wpd_spill_append(wpd_spill *s, int t, const uint64_t *gid, const double *xyz,
                     const uint8_t *halo, const uint8_t *records, size_t n, wpd_error *err)
{
    if (t < 0 || t >= s->ntiles || s->finished)
        return wpd_fail(err, WPD_E_USAGE, "%s: append to tile %d of %d%s", s->dir, t,
                        s->ntiles, s->finished ? " after the spill was finished" : "");
    if (__atomic_load_n(&s->failed, __ATOMIC_ACQUIRE))
        return spill_report_failure(s, err);
    tile *T = &s->tiles[t];
    while (n) {
        if (!T->buf && !(T->buf = wbuf_new(s)))
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for spill buffers", s->dir);
        wbuf *b = T->buf;
        size_t k = s->cap - T->fill < n ? s->cap - T->fill : n;
        memcpy(b->gid + T->fill, gid, k * 8);
        memcpy(b->xyz + 3 * T->fill, xyz, k * 24);
        if (halo)
            memcpy(b->halo + T->fill, halo, k);
        else
            memset(b->halo + T->fill, 0, k);
        if (s->rs)
            memcpy(b->rec + rec_bytes(s, T->fill), records, rec_bytes(s, k));
        T->fill += k;
        T->count += k;
        gid += k, xyz += 3 * k, n -= k;
        halo = halo ? halo + k : NULL;
        records = s->rs ? records + rec_bytes(s, k) : records;
        if (T->fill == s->cap && submit(s, t, 1, err))
            return -1;
    }
    return 0;
}

int wpd_spill_finish(wpd_spill *s, wpd_error *err)
{
    if (s->finished)
        return s->failed ? spill_report_failure(s, err) : 0;
    for (int t = 0; t < s->ntiles && !__atomic_load_n(&s->failed, __ATOMIC_ACQUIRE); t++) {
        wpd_error e;
        if (s->tiles[t].fill && submit(s, t, 0, &e)) {
            /* A failure of submit itself (no memory for the index) must
             * fail the spill too, or the return below would say success. */
            pthread_mutex_lock(&s->mu);
            spill_set_failed_locked(s, &e);
            pthread_mutex_unlock(&s->mu);
            break;
        }
    }
    pthread_mutex_lock(&s->mu);
    while (s->in_flight)
        pthread_cond_wait(&s->cv_idle, &s->mu);
    pthread_mutex_unlock(&s->mu);
    spill_stop_workers(s);
    release_writing(s);
    uint64_t points = 0;
    for (int t = 0; t < s->ntiles; t++)
        points += s->tiles[t].count;
    s->stats.points = points;
    s->finished = 1;
    return s->failed ? spill_report_failure(s, err) : 0;
}

uint64_t wpd_spill_count(const wpd_spill *s, int t)
{
    return t >= 0 && t < s->ntiles ? s->tiles[t].count : 0;
}

void wpd_spill_get_stats(const wpd_spill *s, wpd_spill_stats *st)
{
    pthread_mutex_lock((pthread_mutex_t *)&s->mu);
    *st = s->stats;
    pthread_mutex_unlock((pthread_mutex_t *)&s->mu);
    uint64_t points = 0;
    for (int t = 0; t < s->ntiles; t++)
        points += s->tiles[t].count;
    st->points = points;
}

void wpd_spill_destroy(wpd_spill *s)
{
    if (!s)
        return;
    spill_stop_workers(s);
    release_writing(s);
    if (s->dir[0])
        wpd_tmpdir_remove(s->dir);
    for (int t = 0; t < s->ntiles; t++)
        free(s->tiles[t].chunks);
    free(s->tiles);
    free(s->workers);
    pthread_mutex_destroy(&s->mu);
    pthread_cond_destroy(&s->cv_job);
    pthread_cond_destroy(&s->cv_free);
    pthread_cond_destroy(&s->cv_idle);
    free(s);
}
