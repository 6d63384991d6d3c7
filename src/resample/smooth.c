/* smooth.c - weighted tangent smoothing, tile by tile: each tile's
 * samples with its neighbours' samples within 3 r as context (at their
 * current positions: already smoothed for earlier colours) and a grid over
 * its input points and halo as the surface. Sharp-feature samples stay
 * where they are. The context stays put while a tile is smoothed and the
 * spacing guard keeps the tile's samples clear of it, so a tile smoothed
 * later keeps clear of its neighbours' final positions; no sample strays
 * more than r from its start and the guard looks at most 1.55 r around
 * it, so 3 r of context holds every sample the guard must see. The halo
 * (2.5 r) holds the input points whose cover the tile's samples keep, but
 * for points farther than 1.5 r from every sample (holes the exact count
 * left) just past it: their cover is kept in memory, not quite in tiles. */
#include "resample/smooth.h"
#include "resample/run.h"

#include <stdlib.h>

#include "core/grid.h"
#include "core/knn.h"
#include "method/smooth.h"
#include "resample/sample_store.h"
#include "resample/fixed.h"
#include "resample/hints.h"

static int smooth_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    (void)arg;
    const wpd_params *p = run->p;
    if (wpd_store_count(run, t) == 0)
        return 0;
    double r = run->radius;
    wpd_tile_data d;
    if (wpd_store_load(run, t, err))
        return -1;
    wpd_tile_samples *s = &run->store[t];
    if (wpd_tiles_read(&run->tiles, t, &d, err)) {
        wpd_store_drop(run, t);
        return -1;
    }
    wpd_grid own = {0}, *surface = run->surface.n ? &run->surface : &own;
    double *ctx = NULL;
    uint8_t *ctx_edge = NULL;
    size_t nctx = 0;
    int rc = -1;
    uint32_t *hints = NULL; /* through tiles, the exact count's nearest samples */
    if (surface == &own &&
        (wpd_grid_build_knn(&own, d.xyz, NULL, d.n, p->k, run->surface_dk, threads, err) ||
         wpd_hints_take(run, t, &own, d.n, s->n, &hints, err)))
        goto done;
    if (wpd_run_neighbour_samples(run, t, 3 * r, &ctx, &ctx_edge, &nctx, err) ||
        wpd_fixed_append(run, t, 3 * r, &ctx, &ctx_edge, &nctx, err)) /* earlier nights' */
        goto done;
    wpd_smooth_input in = {s->xyz, s->n, s->edge, ctx, ctx_edge, nctx,
                           surface, run->surface_dk, p->k, p->iterations, r, threads,
                           {p->resolution[0], p->resolution[1], p->resolution[2]},
                           p->even_iterations,
                           /* the exact count's nearest samples: in memory the
                              surface is the run's, its points those d holds */
                           surface == &run->surface ? (nctx == 0 ? run->nearest : NULL)
                                                    : hints,
                           wpd_hints_checked_for_test()};
    wpd_smooth_stats st;
    int failed = wpd_smooth(&in, &st, err);
    free(run->nearest); /* used up: the samples move */
    run->nearest = NULL;
    if (failed)
        goto done;
#pragma omp atomic
    run->res->open_cells += st.open_cells;
#pragma omp atomic
    run->res->pulled_to_surface += st.pulled_to_surface;
#pragma omp atomic
    run->res->non_surface += st.volume_fixed;
#pragma omp atomic
    run->res->isolated += st.isolated_fixed;
#pragma omp atomic
    run->res->guarded_moves += st.shortened + st.refused;
#pragma omp atomic
    run->res->cover_hinted += st.hinted;
    rc = 0;
done:
    free(hints);
    wpd_grid_free(&own);
    free(ctx);
    free(ctx_edge);
    wpd_tiles_release(&run->tiles, &d);
    return wpd_store_finish(run, t, rc, err);
}

int wpd_smooth_phase(wpd_run *run, wpd_error *err)
{
    if (!wpd_params_smooths(run->p))
        return 0;
    run->res->moved = 1;
    int failed = wpd_run_each_tile_shared(run, "smooth", smooth_tile, NULL, NULL, NULL, err);
    wpd_hints_close(run); /* used up */
    if (failed)
        return -1;
    if (!run->owner)
        return 0;
    /* Each rank counted its own tiles' moves: the run's are their sums. */
    wpd_resample_result *r = run->res;
    size_t *count[] = {&r->open_cells, &r->pulled_to_surface, &r->non_surface, &r->isolated,
                       &r->guarded_moves, &r->cover_hinted};
    enum { COUNTS = sizeof count / sizeof *count };
    uint64_t sum[COUNTS];
    for (int i = 0; i < COUNTS; i++)
        sum[i] = *count[i];
    if (wpd_par_sum_u64(run->opt->par, sum, COUNTS, err))
        return -1;
    for (int i = 0; i < COUNTS; i++)
        *count[i] = (size_t)sum[i];
    return 0;
}
