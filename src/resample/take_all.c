/* take_all.c - the run for n at or above the input count: every point is
 * kept as it is, with its sharp label under --sharp. */
#include "resample/poisson.h"
#include "resample/run.h"
#include "resample/sample_store.h"

#include <stdlib.h>
#include <string.h>

#include "core/knn.h"
#include "method/sharp.h"

/* Sharp labels of the points of d, from the input within 2 r0 of each (the
 * capped detector and its support): exact for own points and halo points closer than
 * H - 2 r0 to the box, the ones that are not blind. Every label, for the
 * take-everything run (the Poisson passes ask for theirs: poisson.c). */
static int label_sharp(const wpd_run *run, const wpd_tile_data *d, int threads, uint8_t **edge,
                       wpd_error *err)
{
    wpd_grid surface = {0};
    *edge = malloc(d->n ? d->n : 1);
    if (!*edge)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu edge labels", d->n);
    if (wpd_grid_build_knn(&surface, d->xyz, NULL, d->n, run->p->k, run->surface_dk, threads,
                           err)) {
        wpd_grid_free(&surface);
        return -1;
    }
    wpd_detect_sharp_capped(&surface, 0, d->n, run->res->radius_estimate, *edge, threads);
    wpd_grid_free(&surface);
    return 0;
}

/* n >= the input: every own point is kept as it is, with its sharp label
 * under --sharp (own points see their whole neighbourhood in the halo). */
static int take_all_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    (void)arg;
    wpd_tile_data d;
    if (wpd_tiles_read(&run->tiles, t, &d, err))
        return -1;
    wpd_tile_samples *s = &run->store[t];
    uint8_t *edge = NULL;
    int rc = run->p->sharp ? label_sharp(run, &d, threads, &edge, err) : 0;
    if (rc == 0 && wpd_samples_alloc(s, d.n, edge != NULL))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
    uint64_t sharp = 0;
    for (size_t i = 0; rc == 0 && i < d.n; i++) {
        if (d.halo[i])
            continue;
        s->gid[s->n] = d.gid[i];
        memcpy(s->xyz + 3 * s->n, d.xyz + 3 * i, 3 * sizeof *s->xyz);
        if (edge)
            sharp += s->edge[s->n] = edge[i];
        s->n++;
    }
#pragma omp atomic
    run->res->sharp_points += sharp;
    if (edge) {
#pragma omp atomic
        run->res->sharp_labelled += d.n;
    }
    free(edge);
    wpd_tiles_release(&run->tiles, &d);
    return wpd_store_finish(run, t, rc, err);
}

int wpd_take_all_phase(wpd_run *run, wpd_error *err)
{
    if (wpd_run_each_tile_shared(run, NULL, take_all_tile, NULL, NULL, NULL, err))
        return -1;
    if (!run->owner || run->plan.ntiles < 2)
        return 0;
    /* each rank counted its own tiles' */
    uint64_t sharp[2] = {run->res->sharp_points, run->res->sharp_labelled};
    if (wpd_par_sum_u64(run->opt->par, sharp, 2, err))
        return -1;
    run->res->sharp_points = sharp[0];
    run->res->sharp_labelled = sharp[1];
    return 0;
}
