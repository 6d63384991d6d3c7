/* store_read.c - reading a tile back (see store.h).
 *
 * A read allocates the caller's arrays for the tile's count and scratch
 * for its largest chunk, then reads the chunks in order: the header
 * (checked against the in-memory index, so a damaged or truncated file is
 * an error naming it), the coordinate frame and, only if records are asked
 * for, the record frame. Reads of different tiles, or of the same tile,
 * share nothing but the read-only index, so they can run on any threads.
 */
#include "common/fullio.h"
#include "spill/store.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "spill/codec.h"
#include "spill/planes.h"

/* An output array (never NULL for 0 bytes, so that callers can tell it
 * from a failure). */
static void *alloc_out(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    if (p && bytes >= (8u << 20)) {
        uintptr_t a = ((uintptr_t)p + 4095) & ~(uintptr_t)4095;
        madvise((void *)a, bytes - (a - (uintptr_t)p), MADV_HUGEPAGE);
    }
    return p;
}

void wpd_tile_data_free(wpd_tile_data *d)
{
    if (!d)
        return;
    free(d->gid);
    free(d->xyz);
    free(d->halo);
    free(d->records);
    memset(d, 0, sizeof *d);
}

typedef struct read_scratch {
    uint8_t *file, *coords, *recs;
    uint64_t *scratch;     /* 2 cap values for the codec */
    ZSTD_DCtx *dctx;
} read_scratch;

static void read_scratch_free(read_scratch *r)
{
    free(r->file);
    free(r->coords);
    free(r->recs);
    free(r->scratch);
    ZSTD_freeDCtx(r->dctx);
}

/* Reads and decodes chunk k of tile t into out at point pos. */
static int read_chunk(const wpd_spill *s, int t, uint32_t k, int fd, const char *path,
                      int with_records, read_scratch *r, wpd_tile_data *out, uint64_t pos,
                      wpd_error *err)
{
    const chunk_ref *c = &s->tiles[t].chunks[k];
    size_t len = sizeof(chunk_head) + c->coord_z + (with_records ? c->rec_z : 0);
    ssize_t read_bytes = wpd_pread_full(fd, r->file, len, c->off);
    if (read_bytes != (ssize_t)len) {
        if (read_bytes < 0)
            return wpd_fail_errno(err, "%s: cannot read spill chunk %u", path, k);
        return wpd_fail(err, WPD_E_IO, "%s: spill file truncated: chunk %u at byte %llu "
                        "needs %zu bytes", path, k, (unsigned long long)c->off, len);
    }
    chunk_head h;
    memcpy(&h, r->file, sizeof h);
    if (h.magic != CHUNK_MAGIC || h.tile != (uint32_t)t || h.seq != k || h.n != c->n ||
        h.coord_raw != c->coord_raw || h.coord_z != c->coord_z || h.rec_z != c->rec_z)
        return wpd_fail(err, WPD_E_IO, "%s: corrupt spill chunk %u at byte %llu: header does "
                        "not match what was written", path, k, (unsigned long long)c->off);
    const uint8_t *z = r->file + sizeof h;
    size_t got = ZSTD_decompressDCtx(r->dctx, r->coords, c->coord_raw, z, c->coord_z);
    wpd_error why;
    wpd_error_clear(&why);
    if (ZSTD_isError(got) || got != c->coord_raw ||
        wpd_coords_decode(r->coords, c->coord_raw, c->n, out->gid + pos, out->xyz + 3 * pos,
                          out->halo + pos, r->scratch, &why))
        return wpd_fail(err, WPD_E_IO, "%s: corrupt spill chunk %u at byte %llu: coordinates "
                        "do not decode (%s)", path, k, (unsigned long long)c->off,
                        ZSTD_isError(got) ? ZSTD_getErrorName(got)
                        : why.msg[0]      ? why.msg
                                          : "wrong size");
    if (!with_records || !s->rs)
        return 0;
    size_t want = rec_bytes(s, c->n);
    got = ZSTD_decompressDCtx(r->dctx, r->recs, want, z + c->coord_z, c->rec_z);
    if (ZSTD_isError(got) || got != want)
        return wpd_fail(err, WPD_E_IO, "%s: corrupt spill chunk %u at byte %llu: records do "
                        "not decode (%s)", path, k, (unsigned long long)c->off,
                        ZSTD_isError(got) ? ZSTD_getErrorName(got) : "wrong size");
    wpd_planes_to_records(out->records + rec_bytes(s, pos), r->recs, c->n, s->rs);
    return 0;
}

int wpd_spill_read(const wpd_spill *s, int t, int with_records, wpd_tile_data *out,
                   wpd_error *err)
{
    memset(out, 0, sizeof *out);
    if (t < 0 || t >= s->ntiles || !s->finished)
        return wpd_fail(err, WPD_E_USAGE, "%s: read of tile %d of %d%s", s->dir, t, s->ntiles,
                        s->finished ? "" : " before the spill was finished");
    if (s->failed)
        return spill_report_failure(s, err);
    const tile *T = &s->tiles[t];
    size_t n = T->count, max_len = 0, max_raw = 0, max_n = 0;
    uint64_t sum = 0;
    for (uint32_t k = 0; k < T->nchunks; k++) {
        const chunk_ref *c = &T->chunks[k];
        size_t len = sizeof(chunk_head) + c->coord_z + (with_records ? c->rec_z : 0);
        max_len = len > max_len ? len : max_len;
        max_raw = c->coord_raw > max_raw ? c->coord_raw : max_raw;
        max_n = c->n > max_n ? c->n : max_n;
        sum += c->n;
    }
    char path[1100];
    spill_tile_path(s, t, path, sizeof path);
    if (sum != n)
        return wpd_fail(err, WPD_E_IO, "%s: spill index holds %llu of %zu points", path,
                        (unsigned long long)sum, n);
    out->n = n;
    out->gid = alloc_out(n * 8);
    out->xyz = alloc_out(n * 24);
    out->halo = alloc_out(n);
    out->records = with_records ? alloc_out(rec_bytes(s, n)) : NULL;
    read_scratch r = {malloc(max_len ? max_len : 1), malloc(max_raw ? max_raw : 1),
                      with_records ? malloc(rec_bytes(s, max_n) + 1) : NULL,
                      malloc(2 * s->cap * sizeof(uint64_t)), ZSTD_createDCtx()};
    int rc = 0;
    if (!out->gid || !out->xyz || !out->halo || (with_records && !out->records) || !r.file ||
        !r.coords || (with_records && !r.recs) || !r.scratch || !r.dctx) {
        rc = wpd_fail(err, WPD_E_MEMORY, "%s: out of memory reading %zu spilled points", path, n);
    } else if (T->nchunks) {
        int fd = open(path, O_RDONLY | O_CLOEXEC);
        if (fd < 0)
            rc = wpd_fail_errno(err, "%s: cannot open spill file", path);
        uint64_t pos = 0;
        for (uint32_t k = 0; fd >= 0 && k < T->nchunks && !rc; k++) {
            rc = read_chunk(s, t, k, fd, path, with_records, &r, out, pos, err);
            pos += T->chunks[k].n;
        }
        /* Read-only: nothing can be lost at close, but a failure means
         * the storage is in trouble; say so rather than go on. */
        if (fd >= 0 && close(fd) != 0 && rc == 0)
            rc = wpd_fail_errno(err, "%s: cannot close spill file", path);
    }
    read_scratch_free(&r);
    if (rc)
        wpd_tile_data_free(out);
    return rc;
}
