/* tile.h - the tile pass (internal to src/resample/). */
#ifndef WPD_RESAMPLE_TILE_H
#define WPD_RESAMPLE_TILE_H

#include "common/error.h"
#include "resample/run.h"

/* The spill of a tiled run's points (the tiles, or an outbox of the same
 * tiles). Returns 0 or -1 with err set. */
int wpd_run_open_spill(wpd_run *run, wpd_tiles *tiles, wpd_error *err);


/* The tile pass: every input point to its tile and, within the halo, to
 * its neighbours (spilled, or one tile in memory). */
int wpd_tile_pass(wpd_run *run, wpd_error *err);

#endif
