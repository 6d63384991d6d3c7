/* store_move.c - a tile's compressed chunks taken out of one spill and
 * added to the same tile of another, as they are (see spill.h): the ranks
 * of an MPI run hand the points they read to the tiles' owners this way,
 * without decoding and encoding them again. A chunk is self-contained
 * (its coordinates are coded from its own first point), so it reads back
 * the same in any spill; only its header's tile and sequence number are
 * the new spill's. */
#include "common/fullio.h"
#include "spill/store.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static size_t chunk_len(const chunk_ref *c)
{
    return sizeof(chunk_head) + c->coord_z + c->rec_z;
}

int wpd_spill_tile_chunks(const wpd_spill *s, int t, uint8_t **out, size_t *len,
                          wpd_error *err)
{
    *out = NULL;
    *len = 0;
    if (t < 0 || t >= s->ntiles || !s->finished)
        return wpd_fail(err, WPD_E_USAGE, "%s: chunks of tile %d of %d%s", s->dir, t,
                        s->ntiles, s->finished ? "" : " before the spill was finished");
    if (s->failed)
        return spill_report_failure(s, err);
    const tile *T = &s->tiles[t];
    size_t total = 0;
    for (uint32_t k = 0; k < T->nchunks; k++)
        total += chunk_len(&T->chunks[k]);
    char path[1100];
    spill_tile_path(s, t, path, sizeof path);
    uint8_t *buf = malloc(total ? total : 1);
    if (!buf)
        return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for %zu bytes", path, total);
    int fd = T->nchunks ? open(path, O_RDONLY | O_CLOEXEC) : -1, rc = 0;
    if (T->nchunks && fd < 0)
        rc = wpd_fail_errno(err, "%s: cannot open spill file", path);
    size_t at = 0;
    for (uint32_t k = 0; rc == 0 && k < T->nchunks; k++) {
        const chunk_ref *c = &T->chunks[k];
        ssize_t got = wpd_pread_full(fd, buf + at, chunk_len(c), c->off);
        chunk_head h = {0};
        if (got >= (ssize_t)sizeof h)
            memcpy(&h, buf + at, sizeof h);
        if (got != (ssize_t)chunk_len(c) || h.magic != CHUNK_MAGIC || h.tile != (uint32_t)t ||
            h.seq != k || h.n != c->n)
            rc = got < 0 ? wpd_fail_errno(err, "%s: cannot read spill chunk %u", path, k)
                         : wpd_fail(err, WPD_E_IO, "%s: corrupt spill chunk %u", path, k);
        at += chunk_len(c);
    }
    if (fd >= 0)
        close(fd);
    if (rc) {
        free(buf);
        return -1;
    }
    *out = buf;
    *len = total;
    return 0;
}

/* The chunk at p (at most left bytes) checked against s: *ref its sizes.
 * Returns 0, or -1 when it is no chunk s could have written. */
static int parse_chunk(const wpd_spill *s, const uint8_t *p, size_t left, chunk_ref *ref)
{
    chunk_head h;
    if (left < sizeof h)
        return -1;
    memcpy(&h, p, sizeof h);
    if (h.magic != CHUNK_MAGIC || h.n == 0 || h.n > s->cap || (!s->rs && h.rec_z) ||
        (uint64_t)h.coord_z + h.rec_z > left - sizeof h)
        return -1;
    *ref = (chunk_ref){0, h.n, h.coord_raw, h.coord_z, h.rec_z};
    return 0;
}

/* Writes one chunk (its header renumbered) at the end of tile t's file. */
static int add_chunk(wpd_spill *s, int t, const uint8_t *p, const chunk_ref *ref,
                     wpd_error *err)
{
    tile *T = &s->tiles[t];
    chunk_head h;
    memcpy(&h, p, sizeof h);
    pthread_mutex_lock(&s->mu);
    uint32_t seq = T->nchunks;
    if (T->nchunks == T->chunks_cap) {
        uint32_t cap = T->chunks_cap ? 2 * T->chunks_cap : 16;
        chunk_ref *c = realloc(T->chunks, cap * sizeof *c);
        if (!c) {
            pthread_mutex_unlock(&s->mu);
            return wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the spill index", s->dir);
        }
        T->chunks = c, T->chunks_cap = cap;
    }
    int slot, fd = spill_tile_fd_locked(s, t, &slot);
    uint64_t off = T->file_size;
    size_t len = chunk_len(ref);
    if (fd >= 0) {
        T->nchunks++;
        T->file_size += len;
    }
    pthread_mutex_unlock(&s->mu);
    h.tile = (uint32_t)t;
    h.seq = seq;
    int failed = fd < 0 || wpd_pwrite_full(fd, &h, sizeof h, off) ||
                 wpd_pwrite_full(fd, p + sizeof h, len - sizeof h, off + sizeof h);
    int saved = errno;
    pthread_mutex_lock(&s->mu);
    if (slot >= 0)
        s->open_files[slot].pins--;
    else if (fd >= 0)
        spill_close_tile_fd_locked(s, fd, t);
    if (!failed) {
        T->chunks[seq] = *ref;
        T->chunks[seq].off = off;
        T->count += ref->n;
        s->stats.disk_bytes += len;
        s->stats.raw_bytes += ref->n * (33 + (uint64_t)s->rs);
    }
    pthread_mutex_unlock(&s->mu);
    if (!failed)
        return 0;
    char path[1100];
    spill_tile_path(s, t, path, sizeof path);
    errno = saved;
    wpd_fail_errno(err, "%s: cannot %s spill file", path, fd < 0 ? "create" : "write");
    pthread_mutex_lock(&s->mu);
    spill_set_failed_locked(s, err);
    pthread_mutex_unlock(&s->mu);
    return -1;
}

int wpd_spill_add_chunks(wpd_spill *s, int t, const uint8_t *p, size_t len, wpd_error *err)
{
    if (t < 0 || t >= s->ntiles || s->finished || s->tiles[t].fill)
        return wpd_fail(err, WPD_E_USAGE, "%s: chunks added to tile %d of %d%s", s->dir, t,
                        s->ntiles, s->finished ? " after the spill was finished"
                                   : " that holds points not yet written");
    if (__atomic_load_n(&s->failed, __ATOMIC_ACQUIRE))
        return spill_report_failure(s, err);
    for (size_t at = 0; at < len;) {
        chunk_ref ref;
        if (parse_chunk(s, p + at, len - at, &ref))
            return wpd_fail(err, WPD_E_IO, "%s: tile %d: bytes at %zu are no spill chunk",
                            s->dir, t, at);
        if (add_chunk(s, t, p + at, &ref, err))
            return -1;
        at += chunk_len(&ref);
    }
    return 0;
}
