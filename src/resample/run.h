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
#include "spill/runs.h"
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
    wpd_tile_samples *store;  /* [ntiles] each tile's samples while held in memory
                                 (the sample store below) */
    size_t *count;            /* [ntiles] samples of each tile (store in files) */
    wpd_runs *files;          /* the store in files: run t, tile t's samples; NULL in
                                 memory */
    wpd_runs *border;         /* run t: tile t's samples near its box's faces */
    double halo;              /* halo width */
    double surface_dk;        /* cell of the input-surface grids: about the input's
                                 k-th neighbour distance */
    wpd_grid surface;         /* one in-memory tile: its surface grid, built before
                                 the Poisson passes, which run on it (empty otherwise) */
    wpd_resample_result *res;
    int *owner;               /* [ntiles] the rank that runs each tile where the ranks
                                 share the tiles (ranks.c), or NULL: this process
                                 runs every tile */
} wpd_run;

/* Sizes s for n samples (edge labels when with_edge). Returns 0 or -1 (out
 * of memory; s stays valid for wpd_samples_free). */
int wpd_samples_alloc(wpd_tile_samples *s, size_t n, int with_edge);
void wpd_samples_free(wpd_tile_samples *s);

/* The sample store (sample_store.c). A cloud resampled in memory holds
 * every tile's samples in run->store all along. A tiled run keeps them in
 * files (zstd, spill/runs.h, in their own private directory under the
 * tmpdir): a tile's samples are in run->store[t] only between
 * wpd_store_load and wpd_store_save (or wpd_store_drop), so the memory
 * they take is that of the tiles in flight, whatever n. Each save also
 * writes the tile's border - its samples within WPD_STORE_BAND halos of
 * its box's faces - which holds all a neighbour's view may ask for: the
 * Poisson view's halo (1 halo), smoothing's context (3 r <= 1.2 halos) and
 * the exact count's costs (2 halos; wpd_store_near with dist <= 2 halos).
 * The band's quarter halo more keeps a sample at the very distance asked
 * from being lost to rounding (the distance to the asking tile's box and
 * to the own box's face are computed differently). Calls for different tiles may run at once; a
 * tile must not be saved while another reads its border (colours keep
 * neighbours apart). Errors: WPD_E_IO naming the file, WPD_E_MEMORY. */
#define WPD_STORE_BAND 2.25
int wpd_store_open(wpd_run *run, wpd_error *err);       /* after the plan */
void wpd_store_close(wpd_run *run);
/* Samples of tile t, held or not; over all tiles. */
size_t wpd_store_count(const wpd_run *run, int t);
size_t wpd_run_store_count(const wpd_run *run);
/* Whether the samples carry sharp labels. */
int wpd_store_labelled(const wpd_run *run);
/* Empties every tile. */
void wpd_run_store_clear(wpd_run *run);
/* Makes run->store[t] hold tile t's samples (nothing to do when held). */
int wpd_store_load(wpd_run *run, int t, wpd_error *err);
/* Writes run->store[t] back and lets it go (in memory: nothing). Returns
 * 0 or -1; either way the arrays are no longer held. */
int wpd_store_save(wpd_run *run, int t, wpd_error *err);
/* Lets run->store[t] go unchanged (in memory: nothing). */
void wpd_store_drop(wpd_run *run, int t);
/* Tile u's samples within dist of tile t's box (u != t, dist at most 2
 * halos), ascending by gid, into out (malloc'd). Returns 0 or -1. */
int wpd_store_near(const wpd_run *run, int t, int u, double dist, wpd_tile_samples *out,
                   wpd_error *err);

/* Samples of t's neighbours within dist of t's box (frame coordinates, at
 * their current positions), malloc'd into *out, and their sharp labels into
 * *edge (NULL when the samples carry none). Returns 0 or -1 with err set. */
int wpd_run_neighbour_samples(const wpd_run *run, int t, double dist, double **out,
                              uint8_t **edge, size_t *n, wpd_error *err);

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

/* What a phase keeps about a tile beside its samples, handed between the
 * ranks with them: pack appends it to out (a failure shows in out->failed),
 * unpack takes it from in on another rank (0, or -1 with err set). */
typedef struct wpd_tile_share {
    void (*pack)(const wpd_run *run, int t, void *arg, wpd_bytes *out);
    int (*unpack)(wpd_run *run, int t, void *arg, wpd_bytes_in *in, wpd_error *err);
    int keep_samples;         /* 1: the phase leaves the samples as they were (every
                                 rank has them already): only pack/unpack travel */
} wpd_tile_share;

/* wpd_run_each_tile with the tiles shared between the ranks of an MPI run
 * (par/par.h): each rank runs the tiles it owns, and after each colour
 * every rank gets the colour's tiles from their owners
 * (wpd_run_share_colour): their samples into its store, and through extra
 * (may be NULL) the phase's state of each tile; then after_colour runs on
 * every rank alike. So fn must leave a tile's result in the store and in
 * what extra carries (counters in run->res: this rank's tiles only).
 * Without owners, wpd_run_each_tile. */
int wpd_run_each_tile_shared(wpd_run *run, const char *phase, wpd_tile_fn fn,
                             wpd_colour_fn after_colour, const wpd_tile_share *extra,
                             void *arg, wpd_error *err);

/* wpd_run_tiles_any_order with the tiles shared between the ranks: each
 * rank runs its own, then every rank gets every other tile from its owner
 * as wpd_run_each_tile_shared hands them on. */
int wpd_run_tiles_any_order_shared(wpd_run *run, const char *phase, wpd_tile_fn fn,
                                   const wpd_tile_share *extra, void *arg, wpd_error *err);

/* Ranks (ranks.c). The owner of each tile, for more than one rank:
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

/* Runs fn on every tile in any order, as many at once as the threads and
 * the budget allow, without waiting between colours: for work whose result
 * does not depend on the order of the tiles (fn sees no other tile's work
 * of the same call). Returns 0, or -1 with the first failure in err. */
int wpd_run_tiles_any_order(wpd_run *run, const char *phase, wpd_tile_fn fn, void *arg,
                            wpd_error *err);

/* The spill of a tiled run's points (driver.c): run->tiles, or an
 * outbox of the same tiles (tile.c). Returns 0 or -1 with err set. */
int wpd_run_open_spill(wpd_run *run, wpd_tiles *tiles, wpd_error *err);

/* Where each rank read a block of the inputs into outbox (finished), a
 * spill of every tile: tile by tile, every rank's points go to the tile's
 * owner, which appends them to run->tiles in rank order (tile_share.c).
 * Every rank calls it; agrees before each exchange. Returns 0, or -1 with
 * err set. */
int wpd_run_send_tiles(wpd_run *run, const wpd_tiles *outbox, wpd_error *err);

/* Phases (each in its own file). */
int wpd_tile_pass(wpd_run *run, wpd_error *err);                 /* tile.c */
int wpd_poisson_phase(wpd_run *run, wpd_error *err);             /* poisson_pass.c */
int wpd_take_all_phase(wpd_run *run, wpd_error *err);            /* take_all.c */
int wpd_exact_phase(wpd_run *run, wpd_error *err);               /* exact_pass.c */
int wpd_smooth_phase(wpd_run *run, wpd_error *err);              /* smooth_pass.c */
int wpd_merge_phase(wpd_run *run, wpd_error *err);               /* merge.c */

#endif
