/* run.h - the state one resampling run shares between its phases
 * (internal to src/resample/; callers use resample.h).
 *
 * Samples live per tile (the store), in global-index order within a tile;
 * the flat steps (exact count, merge) see them all at once.
 */
#ifndef WPD_RUN_H
#define WPD_RUN_H

#include <stddef.h>
#include <stdint.h>

#include "common/first_error.h"
#include "resample/plan.h"
#include "resample/resample.h"
#include "resample/scan.h"
#include "resample/tiles.h"
#include "core/grid.h"
#include "wpd/poisson.h"

/* The samples one tile accepted. */
typedef struct wpd_tile_samples {
    size_t n;
    uint64_t *gid;            /* ascending */
    double *xyz;              /* frame coordinates */
    uint8_t *edge;            /* sharp-feature label, or NULL without --sharp */
} wpd_tile_samples;

typedef struct wpd_run {
    const wpd_resample_options *opt;
    const wpd_params *p;
    wpd_cloud *cloud;
    uint32_t record_size;
    int threads;
    wpd_scan scan;
    wpd_plan plan;
    wpd_tiles tiles;
    wpd_tile_samples *store;  /* [ntiles] */
    double halo;              /* halo width */
    double surface_dk;        /* cell of the input-surface grids: about the input's
                                 k-th neighbour distance */
    wpd_grid surface;         /* one in-memory tile: its surface grid, built beside
                                 the Poisson passes (empty otherwise) */
    wpd_resample_result *res;
} wpd_run;

/* Sizes s for n samples (edge labels when with_edge). Returns 0 or -1 (out
 * of memory; s stays valid for wpd_samples_free). */
int wpd_samples_alloc(wpd_tile_samples *s, size_t n, int with_edge);
void wpd_samples_free(wpd_tile_samples *s);
/* Frees every tile's samples. */
void wpd_run_store_clear(wpd_run *run);
/* Samples over all tiles. */
size_t wpd_run_store_count(const wpd_run *run);

/* Samples of t's neighbours within dist of t's box (frame coordinates, at
 * their current positions), malloc'd into *out, and their sharp labels into
 * *edge (NULL when the samples carry none). Returns 0 or -1. */
int wpd_run_neighbour_samples(const wpd_run *run, int t, double dist, double **out,
                              uint8_t **edge, size_t *n);

/* Work on one tile; threads: the threads it may use. */
typedef int (*wpd_tile_fn)(wpd_run *run, int t, int threads, void *arg, wpd_error *err);

/* Work after the tiles of one colour are done, on one thread. */
typedef int (*wpd_colour_fn)(wpd_run *run, int colour, void *arg, wpd_error *err);

/* Runs fn on every tile, colour by colour, the tiles of a colour in
 * parallel (one tile: all threads inside it), then after_colour (may be
 * NULL) once per colour. Tiles of one colour are never neighbours, so each
 * sees exactly the work of its neighbours of earlier colours, whatever the
 * threads. phase: a progress phase of ntiles "tiles", or NULL for none.
 * Returns 0, or -1 with the first failure in err. */
int wpd_run_each_tile(wpd_run *run, const char *phase, wpd_tile_fn fn,
                      wpd_colour_fn after_colour, void *arg, wpd_error *err);

/* Runs fn on every tile in any order, as many at once as the threads and
 * the budget allow, without waiting between colours: for work whose result
 * does not depend on the order of the tiles (fn sees no other tile's work
 * of the same call). Returns 0, or -1 with the first failure in err. */
int wpd_run_tiles_any_order(wpd_run *run, const char *phase, wpd_tile_fn fn, void *arg,
                            wpd_error *err);

/* Phases (each in its own file). */
int wpd_tile_pass(wpd_run *run, wpd_error *err);                 /* tile.c */
int wpd_poisson_phase(wpd_run *run, wpd_error *err);             /* poisson_pass.c */
int wpd_take_all_phase(wpd_run *run, wpd_error *err);            /* poisson_pass.c */
int wpd_exact_phase(wpd_run *run, wpd_error *err);               /* exact_pass.c */
int wpd_smooth_phase(wpd_run *run, wpd_error *err);              /* smooth_pass.c */
int wpd_merge_phase(wpd_run *run, wpd_error *err);               /* merge.c */

#endif
