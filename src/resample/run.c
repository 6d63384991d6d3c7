/* run.c - the tile loops: colour by colour, or in any order. */
#include "resample/run.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "resample/budget.h"
#include "resample/ranks.h"

/* After colour c: with the ranks sharing the tiles, each tile's samples go
 * from its owner to every rank (ranks.c), agreeing first on the failure fe
 * holds, if any. Returns 0, or -1 with the failure in fe. */
static int share(wpd_run *run, int c, const wpd_tile_share *extra, void *arg,
                 wpd_first_error *fe)
{
    wpd_error e = {0};
    wpd_first_error_take(fe, &e);
    if (wpd_run_share_colour(run, c, extra, arg, &e) == 0)
        return 0;
    wpd_first_error_keep(fe, &e);
    return -1;
}

/* Every tile through fn: colour by colour when ordered (after_colour after
 * each), else all at once in one colour-blind loop. shared: each rank runs
 * the tiles it owns, and after each colour (unordered: after all tiles)
 * every rank gets the others' tiles. */
static int run_tiles(wpd_run *run, const char *phase, wpd_tile_fn fn,
                     wpd_colour_fn after_colour, void *arg, int ordered, int shared,
                     const wpd_tile_share *extra, wpd_error *err)
{
    shared = shared && run->owner;
    int ntiles = run->plan.ntiles;
    int workers = wpd_budget_tile_workers(run->threads, ntiles);
    int inside = wpd_budget_threads_per_tile(run->threads, ntiles);
    int rounds = ordered ? run->plan.ncolours : 1;
    wpd_first_error fe = {0};
    if (phase)
        wpd_progress_phase(run->opt->progress, phase, (uint64_t)ntiles, "tiles");
    int broke = 0;
    for (int c = 0; c < rounds && (shared || !wpd_first_error_failed(&fe)); c++) {
#pragma omp parallel for num_threads(workers) schedule(dynamic, 1)
        for (int t = 0; t < ntiles; t++) {
            if ((ordered && run->plan.tiles[t].colour != c) || wpd_first_error_failed(&fe) ||
                (shared && !wpd_run_owns(run, t)))
                continue;
            wpd_error local = {0};
            if (fn(run, t, inside, arg, &local))
                wpd_first_error_keep(&fe, &local);
            wpd_progress_add(run->opt->progress, 1);
        }
        if (shared && share(run, ordered ? c : -1, extra, arg, &fe)) {
            broke = 1;
            break;
        }
        wpd_error local = {0};
        if (!wpd_first_error_failed(&fe) && after_colour && after_colour(run, c, arg, &local))
            wpd_first_error_keep(&fe, &local);
    }
    if (phase)
        wpd_progress_end(run->opt->progress);
    if (!shared || broke) /* broke: a failure the ranks agreed on, or this rank's
                             own unpacking, which the others meet in their next
                             agreement */
        return wpd_first_error_take(&fe, err);
    /* The last after_colour and unpacking may have failed on one rank only:
     * the caller's next exchange (a sum) must follow an agreement. */
    wpd_error_clear(err);
    wpd_first_error_take(&fe, err);
    return wpd_par_agree(run->opt->par, err);
}

int wpd_run_each_tile_shared(wpd_run *run, const char *phase, wpd_tile_fn fn,
                             wpd_colour_fn after_colour, const wpd_tile_share *extra,
                             void *arg, wpd_error *err)
{
    return run_tiles(run, phase, fn, after_colour, arg, 1, 1, extra, err);
}

int wpd_run_tiles_any_order_shared(wpd_run *run, const char *phase, wpd_tile_fn fn,
                                   const wpd_tile_share *extra, void *arg, wpd_error *err)
{
    return run_tiles(run, phase, fn, NULL, arg, 0, 1, extra, err);
}
