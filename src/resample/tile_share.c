/* tile_share.c - the tile pass's points to their tiles' owners, where the
 * ranks of an MPI run each read a block of the inputs (tile.c): every
 * rank has spilled its block's points for every tile; tile by tile, each
 * sends its part, the compressed chunks as spilled, to the tile's owner,
 * which appends the parts in rank order. The blocks follow each other in
 * global-index order, so the owner's tile holds its points in the order
 * one process reads them (in other chunks: the points decode the same). */
#include "resample/tile_share.h"
#include "resample/run.h"
#include "resample/ranks.h"

#include <stdlib.h>
#include <string.h>

int wpd_run_send_tiles(wpd_run *run, const wpd_tiles *outbox, wpd_error *err)
{
    const wpd_par *par = run->opt->par;
    int ranks = wpd_par_ranks(par);
    size_t *off = calloc((size_t)ranks, sizeof *off), *len = calloc((size_t)ranks, sizeof *len);
    int rc = off && len ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int t = 0; t < run->plan.ntiles; t++) {
        uint8_t *mine = NULL, *all = NULL;
        size_t n = 0;
        if (rc == 0)
            rc = wpd_tiles_chunks(outbox, t, &mine, &n, err);
        if (rc == 0)
            wpd_error_clear(err);
        /* A failure anywhere (this rank's read or append, another's) fails
         * every rank here. */
        rc = wpd_par_agree(par, err) ||
                     wpd_par_gather_to(par, run->owner[t], mine, n, &all, off, len, err)
                 ? -1 : 0;
        free(mine);
        for (int k = 0; rc == 0 && wpd_run_owns(run, t) && k < ranks; k++)
            if (len[k])
                rc = wpd_tiles_add_chunks(&run->tiles, t, all + off[k], len[k], err);
        free(all);
        if (rc)
            break;
    }
    free(off);
    free(len);
    return rc;
}
