/* tile_share.c - the tile pass's points to their tiles' owners, where the
 * ranks of an MPI run each read a block of the inputs (tile.c): every
 * rank has spilled its block's points for every tile; tile by tile, each
 * sends its part to the tile's owner, which appends the parts in rank
 * order. The blocks follow each other in global-index order, so the owner
 * appends its tile's points in the order one process reads them. */
#include "resample/run.h"

#include <stdlib.h>
#include <string.h>

#include "common/bytes.h"

/* A tile's points as bytes: n, then the global indices, coordinates and
 * halo flags, padded to 8 bytes (parts gathered one after the other stay
 * aligned). */
static void pack_points(const wpd_tile_data *d, wpd_bytes *b)
{
    static const uint8_t zeros[8] = {0};
    wpd_bytes_put_u64(b, d->n);
    wpd_bytes_put(b, d->gid, d->n * sizeof *d->gid);
    wpd_bytes_put(b, d->xyz, 3 * d->n * sizeof *d->xyz);
    wpd_bytes_put(b, d->halo, d->n);
    wpd_bytes_put(b, zeros, (8 - d->n % 8) % 8);
}

/* The owner: every rank's part of tile t, in rank order, appended. */
static int append_parts(wpd_run *run, int t, const uint8_t *all, const size_t *off,
                        const size_t *len, int ranks, wpd_error *err)
{
    for (int k = 0; k < ranks; k++) {
        const uint8_t *p = all + off[k];
        uint64_t n = 0;
        if (len[k] >= 8)
            memcpy(&n, p, 8);
        if (len[k] < 8 || n > (len[k] - 8) / 33 || len[k] != 8 + 33 * n + (8 - n % 8) % 8)
            return wpd_fail(err, WPD_E_IO, "tile %d: rank %d's points are cut short", t, k);
        const uint64_t *gid = (const uint64_t *)(p + 8);
        const double *xyz = (const double *)(gid + n);
        const uint8_t *halo = (const uint8_t *)(xyz + 3 * n);
        if (n && wpd_tiles_append(&run->tiles, t, gid, xyz, halo, (size_t)n, err))
            return -1;
    }
    return 0;
}

int wpd_run_send_tiles(wpd_run *run, const wpd_tiles *outbox, wpd_error *err)
{
    const wpd_par *par = run->opt->par;
    int ranks = wpd_par_ranks(par);
    size_t *off = calloc((size_t)ranks, sizeof *off), *len = calloc((size_t)ranks, sizeof *len);
    int rc = off && len ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int t = 0; t < run->plan.ntiles; t++) {
        wpd_tile_data d = {0};
        wpd_bytes b = {0};
        if (rc == 0 && wpd_tiles_read(outbox, t, &d, err) == 0) {
            pack_points(&d, &b);
            wpd_tiles_release(outbox, &d);
            if (b.failed)
                rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for tile %d's points", t);
        } else if (rc == 0) {
            rc = -1;
        }
        if (rc == 0)
            wpd_error_clear(err);
        uint8_t *all = NULL;
        /* A failure anywhere (this rank's read or append, another's) fails
         * every rank here. */
        rc = wpd_par_agree(par, err) ||
                     wpd_par_gather_to(par, run->owner[t], b.p, b.len, &all, off, len, err)
                 ? -1 : 0;
        wpd_bytes_free(&b);
        if (rc) {
            free(all);
            break;
        }
        if (wpd_run_owns(run, t))
            rc = append_parts(run, t, all, off, len, ranks, err);
        free(all);
    }
    free(off);
    free(len);
    return rc;
}
