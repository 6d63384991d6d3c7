/* ranks.h - the tiles shared between the ranks of an MPI run
 * (internal to src/resample/). */
#ifndef WPD_RESAMPLE_RANKS_H
#define WPD_RESAMPLE_RANKS_H

#include "common/bytes.h"
#include "common/error.h"
#include "resample/run.h"

/* The owner of each tile, for more than one rank:
 * colour by colour, the largest tiles first, each to the rank with the
 * fewest points of the colour so far (run->owner). Returns 0 or -1. */
int wpd_run_assign_owners(wpd_run *run, wpd_error *err);
/* Whether this rank runs tile t. */
int wpd_run_owns(const wpd_run *run, int t);
/* Whether each rank spills only its own tiles' points: the ranks share
 * the tiles and there are several (one tile, in memory or not, every rank
 * holds whole and runs its Poisson passes). */
static inline int wpd_run_spills_own_tiles(const wpd_run *run)
{
    return run->owner && !run->res->in_memory && run->plan.ntiles > 1;
}
/* After the tiles of colour c (-1: all tiles) ran: agrees on err (this
 * rank's failure, or WPD_OK), then every rank gets each such tile's
 * samples from its owner into its store, and extra's state. Returns 0, or
 * -1 with err set (the failure agreed). */
int wpd_run_share_colour(wpd_run *run, int colour, const wpd_tile_share *extra, void *arg,
                         wpd_error *err);
/* A tile's samples as bytes, and back (0, or -1: out of memory or bytes
 * that are no samples; in->bad tells which). */
void wpd_samples_pack(const wpd_tile_samples *s, wpd_bytes *out);
int wpd_samples_unpack(wpd_tile_samples *s, wpd_bytes_in *in);

#endif
