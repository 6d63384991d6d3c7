/* tile_share.h - the tile pass's points handed to their tiles' owners
 * (internal to src/resample/). */
#ifndef WPD_RESAMPLE_TILE_SHARE_H
#define WPD_RESAMPLE_TILE_SHARE_H

#include "common/error.h"
#include "resample/run.h"

/* Where each rank read a block of the inputs into outbox (finished), a
 * spill of every tile: tile by tile, every rank's points go to the tile's
 * owner, which appends them to run->tiles in rank order.
 * Every rank calls it; agrees before each exchange. Returns 0, or -1 with
 * err set. */
int wpd_run_send_tiles(wpd_run *run, const wpd_tiles *outbox, wpd_error *err);

#endif
