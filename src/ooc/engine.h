/* engine.h - out-of-core Weighted Poisson-disk resampling.
 *
 * The pipeline (docs/engine.md):
 *   scan    one streaming pass (two for inputs without a declared box or
 *           with a wrong one): finite points per file, occupied voxels
 *           (-> one global radius), a coarse density grid;
 *   plan    tiles of density-grid cells that fit the memory budget, their
 *           neighbours and a colouring;
 *   tile    a streaming pass writes every point (global index, frame
 *           coordinates, halo flag) to its tile and, within the halo, to its
 *           neighbours, as zstd-compressed spill files;
 *   poisson colour by colour, tiles of a colour in parallel, each seeing the
 *           samples its finished neighbours accepted (no two samples closer
 *           than r across a border); counts summed over tiles drive the
 *           global refinement; an overshooting pass is pruned in memory;
 *   exact   the global exact count over all samples;
 *   smooth  colour by colour again: each tile smooths its samples with its
 *           neighbours' samples as context and its input (with halo) as the
 *           surface;
 *   merge   samples sorted by global index: the output order, whatever the
 *           threads; their records from a last streaming pass.
 * Every pass keeps within the budget: a thread beyond the first runs only
 * where the budget holds its own working set.
 * The samples themselves (about n of them) stay in memory; the input never
 * does, beyond the tiles in flight.
 */
#ifndef WPD_ENGINE_H
#define WPD_ENGINE_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "common/progress.h"
#include "io/cloud.h"
#include "spill/spill.h"
#include "wpd/wpd.h"

typedef struct wpd_engine_options {
    uint64_t target;          /* n (>= 1) */
    size_t mem_bytes;         /* memory budget */
    const char *tmpdir;       /* directory for the private spill directory */
    int min_tiles;            /* at least this many tiles (tests, benchmarks) */
    wpd_params params;        /* the method's parameters; threads */
    wpd_progress *progress;   /* phase progress, or NULL */
} wpd_engine_options;

typedef struct wpd_engine_timings {
    double bounds, scan, plan, tile, poisson, exact, smooth, merge, total;
} wpd_engine_timings;

typedef struct wpd_engine_result {
    size_t count;             /* samples (n, or every point when n >= input) */
    uint64_t *gid;            /* [count] ascending global indices */
    double *xyz;              /* [3 count] absolute coordinates */
    uint8_t *records;         /* [count * record_size] */
    uint32_t record_size;
    uint64_t input_points;    /* finite input points */
    int nfiles;
    uint64_t *file_count;     /* [nfiles] finite points per input file */
    double radius_estimate, radius;
    size_t first_pass_count, poisson_count;
    int full_passes, prune_passes;
    int tiles, colours;
    uint64_t largest_tile;
    double *tile_box;         /* [6 tiles]: min x y z, max x y z of each tile, absolute,
                                 outer faces at the data's bounds */
    size_t open_cells, pulled_to_surface;
    wpd_spill_stats spill;
    wpd_engine_timings time;
} wpd_engine_result;

/* Bytes the engine budgets per point of a tile in flight, and per sample. */
size_t wpd_engine_bytes_per_tile_point(uint32_t record_size);
size_t wpd_engine_bytes_per_sample(uint32_t record_size);

/* Tiles are sized so that this many fit the budget at once, whatever the
 * number of threads: the tiling, and so the output, must not depend on it.
 * At most this many tiles are in flight; more threads than that do not
 * speed the tile phases up. */
#define WPD_ENGINE_TILES_IN_FLIGHT 4

/* Smallest useful budget for target samples of record_size bytes; below it
 * wpd_engine_run refuses to start. */
size_t wpd_engine_min_budget(uint64_t target, uint32_t record_size);

/* Resamples cloud to opt->target points. Returns 0 (res filled, free with
 * wpd_engine_result_free), or -1 with err set: WPD_E_MEMORY when the budget
 * is too small (before any work), WPD_E_IO, WPD_E_INPUT. Spill files are
 * removed on every path. */
int wpd_engine_run(wpd_cloud *cloud, const wpd_engine_options *opt, wpd_engine_result *res,
                   wpd_error *err);

void wpd_engine_result_free(wpd_engine_result *res);

#endif
