/* fixed.h - samples of earlier runs that a run keeps (internal to
 * src/resample/): a collection's later night (docs/ingest.md) resamples
 * only its new inputs, and the samples earlier nights wrote within reach
 * of them act as the accepted samples of neighbouring tiles do:
 *   poisson  fixed points, no new sample within r of them;
 *   exact    present for coverage and crowding (an input point near one
 *            is covered by it), never candidates, never deleted;
 *   smooth   context samples: never moved, the guards keep clear of them.
 * Each phase asks for those within its reach of a tile's box (in the
 * frame), at most 2.25 halos, as it asks the sample store for a
 * neighbour's samples. They are never written. In the exact count's views
 * they carry the global indices WPD_FIXED_GID + their place in the list:
 * after every input point and in one order in every tile, so ties break
 * alike whatever the tiling. */
#ifndef WPD_RESAMPLE_FIXED_H
#define WPD_RESAMPLE_FIXED_H

#include "resample/run.h"

#define WPD_FIXED_GID ((uint64_t)1 << 62)

/* After the plan: opt->fixed_xyz into the frame, listed per tile.
 * Returns 0, or -1 with err set (WPD_E_MEMORY). */
int wpd_fixed_open(wpd_run *run, wpd_error *err);
void wpd_fixed_close(wpd_run *run);

/* The fixed samples within dist (<= 2.25 halos) of tile t's box into out
 * (malloc'd; gids as above, no labels: radius r). Returns 0 or -1. */
int wpd_fixed_near(const wpd_run *run, int t, double dist, wpd_tile_samples *out,
                   wpd_error *err);

/* Appends the fixed samples within dist of tile t's box to the n points
 * of *xyz (realloc'd) and, when *edge is not NULL, zero labels to *edge.
 * Returns 0 or -1 with err set. */
int wpd_fixed_append(const wpd_run *run, int t, double dist, double **xyz, uint8_t **edge,
                     size_t *n, wpd_error *err);

#endif
