/* run.h - the state one resampling run shares between its phases
 * (internal to src/resample/; callers use resample.h).
 *
 * Samples live per tile (the sample store below), in global-index order
 * within a tile.
 */
#ifndef WPD_RUN_H
#define WPD_RUN_H

#include <stddef.h>
#include <stdint.h>

#include "common/bytes.h"
#include "common/first_error.h"
#include "resample/plan.h"
#include "resample/resample.h"
#include "resample/scan.h"
#include "resample/tiles.h"
#include "spill/blobs.h"
#include "spill/runs.h"
#include "core/grid.h"
#include "method/poisson.h"

/* The samples one tile accepted. */
typedef struct wpd_tile_samples {
    size_t n;
    uint64_t *gid;            /* ascending */
    double *xyz;              /* frame coordinates */
    uint8_t *edge;            /* sharp-feature label, or NULL without --sharp */
} wpd_tile_samples;

/* Samples of earlier runs the run keeps (resample.h, fixed_xyz), in the
 * frame, with the ones near each tile listed (fixed.c). */
typedef struct wpd_fixed {
    size_t n;
    double *xyz;              /* [3n] frame coordinates */
    uint32_t **of_tile;       /* [ntiles] the samples within 2.25 halos of its box */
    size_t *nof_tile;
} wpd_fixed;

typedef struct wpd_run {
    const wpd_resample_options *opt;
    const wpd_params *p;
    wpd_params fixed_params;  /* opt->params with the fixed radius (p points here) */
    wpd_fixed fixed;          /* earlier runs' samples (none: n = 0) */
    double plan_target;       /* the count the plan and the surface grids are sized
                                 for: the target, or with a fixed radius the count
                                 the scan's voxels predict at it */
    wpd_cloud *cloud;
    uint32_t record_size;
    int threads;
    wpd_scan scan;
    wpd_plan plan;
    wpd_tiles tiles;
    wpd_tile_samples *store;  /* [ntiles] each tile's samples while held in memory
                                 (the sample store below) */
    size_t *count;            /* [ntiles] samples of each tile (store in files) */
    wpd_runs *files;          /* the store in files: run t, tile t's samples; NULL in
                                 memory */
    wpd_runs *border;         /* run t: tile t's samples near its box's faces */
    double radius;            /* the working radius: the estimate, then each Poisson
                                 pass's (the result gets the final one) */
    double halo;              /* halo width */
    double surface_dk;        /* cell of the input-surface grids: about the input's
                                 k-th neighbour distance */
    wpd_grid surface;         /* one in-memory tile: its surface grid, built before
                                 the Poisson passes, which run on it (empty otherwise) */
    uint32_t *nearest;        /* one in-memory tile that is smoothed, with no earlier
                                 nights' samples: per input point (the surface grid's
                                 slots), its nearest sample (index in the store) as
                                 the exact count's last sweep
                                 found it, or WPD_SMOOTH_NO_NEAREST; smoothing's cover
                                 starts from it (NULL: none, or not kept) */
    struct wpd_blobs *hints;  /* tiled and smoothed: the exact count's nearest samples
                                 per tile for smoothing (hints.h), or NULL */
    wpd_blobs_use work_files; /* bytes of the exact count's files and the hints' */
    wpd_resample_result *res;
    int *owner;               /* [ntiles] the rank that runs each tile where the ranks
                                 share the tiles (ranks.c), or NULL: this process
                                 runs every tile */
} wpd_run;

/* Work on one tile; threads: the threads it may use. */
typedef int (*wpd_tile_fn)(wpd_run *run, int t, int threads, void *arg, wpd_error *err);

/* Work after the tiles of one colour are done, on one thread. */
typedef int (*wpd_colour_fn)(wpd_run *run, int colour, void *arg, wpd_error *err);

/* What a phase keeps about a tile beside its samples, handed between the
 * ranks with them: pack appends it to out (a failure shows in out->failed),
 * unpack takes it from in on another rank (0, or -1 with err set). */
typedef struct wpd_tile_share {
    void (*pack)(const wpd_run *run, int t, void *arg, wpd_bytes *out);
    int (*unpack)(wpd_run *run, int t, void *arg, wpd_bytes_in *in, wpd_error *err);
    int keep_samples;         /* 1: the phase leaves the samples as they were (every
                                 rank has them already): only pack/unpack travel */
} wpd_tile_share;

/* Runs fn on every tile, colour by colour, the tiles of a colour in
 * parallel (one tile: all threads inside it), then after_colour (may be
 * NULL) once per colour. Tiles of one colour are never neighbours, so each
 * sees exactly the work of its neighbours of earlier colours, whatever the
 * threads. phase: a progress phase of ntiles "tiles", or NULL for none.
 * Where the ranks of an MPI run share the tiles (par/par.h, run->owner),
 * each rank runs the tiles it owns, and after each colour every rank gets
 * the colour's tiles from their owners (ranks.h, wpd_run_share_colour):
 * their samples into its store, and through extra (may be NULL) the
 * phase's state of each tile; then after_colour runs on every rank alike.
 * So fn must leave a tile's result in the store and in what extra carries
 * (counters in run->res: this rank's tiles only). Returns 0, or -1 with
 * the first failure in err. */
int wpd_run_each_tile_shared(wpd_run *run, const char *phase, wpd_tile_fn fn,
                             wpd_colour_fn after_colour, const wpd_tile_share *extra,
                             void *arg, wpd_error *err);

/* Runs fn on every tile in any order, as many at once as the threads and
 * the budget allow, without waiting between colours: for work whose result
 * does not depend on the order of the tiles (fn sees no other tile's work
 * of the same call). With the tiles shared between the ranks, each rank
 * runs its own, then every rank gets every other tile from its owner as
 * wpd_run_each_tile_shared hands them on. Returns 0, or -1 with the first
 * failure in err. */
int wpd_run_tiles_any_order_shared(wpd_run *run, const char *phase, wpd_tile_fn fn,
                                   const wpd_tile_share *extra, void *arg, wpd_error *err);

/* The count the exact count cuts down to: the target, or with a density
 * factor f round(f x the Poisson pass's samples) (driver.c). */
size_t wpd_run_exact_target(const wpd_run *run);

#endif
