/* run.c - the per-tile sample store and the colour-by-colour tile loop. */
#include "resample/run.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "resample/budget.h"

int wpd_samples_alloc(wpd_tile_samples *s, size_t n, int with_edge)
{
    size_t m = n ? n : 1;
    memset(s, 0, sizeof *s);
    s->gid = malloc(m * sizeof *s->gid);
    s->xyz = malloc(3 * m * sizeof *s->xyz);
    s->edge = with_edge ? calloc(m, 1) : NULL;
    return s->gid && s->xyz && (s->edge || !with_edge) ? 0 : -1;
}

void wpd_samples_free(wpd_tile_samples *s)
{
    free(s->gid);
    free(s->xyz);
    free(s->edge);
    memset(s, 0, sizeof *s);
}

void wpd_run_store_clear(wpd_run *run)
{
    for (int t = 0; run->store && t < run->plan.ntiles; t++)
        wpd_samples_free(&run->store[t]);
}

size_t wpd_run_store_count(const wpd_run *run)
{
    size_t total = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        total += run->store[t].n;
    return total;
}

int wpd_run_neighbour_samples(const wpd_run *run, int t, double dist, double **out,
                              uint8_t **edge, size_t *n)
{
    const wpd_tile *tile = &run->plan.tiles[t];
    size_t cap = 0;
    int labelled = 0;
    for (int j = 0; j < tile->nadj; j++) {
        cap += run->store[tile->adj[j]].n;
        labelled |= run->store[tile->adj[j]].edge != NULL;
    }
    *out = malloc((cap ? cap : 1) * 3 * sizeof **out);
    *edge = labelled ? calloc(cap ? cap : 1, 1) : NULL;
    *n = 0;
    if (!*out || (labelled && !*edge))
        return -1;
    for (int j = 0; j < tile->nadj; j++) {
        const wpd_tile_samples *s = &run->store[tile->adj[j]];
        for (size_t i = 0; i < s->n; i++)
            if (wpd_tile_distance(tile, s->xyz + 3 * i) < dist) {
                memcpy(*out + 3 * *n, s->xyz + 3 * i, 3 * sizeof **out);
                if (s->edge)
                    (*edge)[*n] = s->edge[i];
                (*n)++;
            }
    }
    return 0;
}

/* Every tile through fn: colour by colour when ordered (after_colour after
 * each), else all at once in one colour-blind loop. */
static int run_tiles(wpd_run *run, const char *phase, wpd_tile_fn fn,
                     wpd_colour_fn after_colour, void *arg, int ordered, wpd_error *err)
{
    int ntiles = run->plan.ntiles;
    int workers = wpd_budget_tile_workers(run->threads, ntiles);
    int inside = wpd_budget_threads_per_tile(run->threads, ntiles);
    int rounds = ordered ? run->plan.ncolours : 1;
    wpd_first_error fe = {0};
    if (phase)
        wpd_progress_phase(run->opt->progress, phase, (uint64_t)ntiles, "tiles");
    for (int c = 0; c < rounds && !wpd_first_error_failed(&fe); c++) {
#pragma omp parallel for num_threads(workers) schedule(dynamic, 1)
        for (int t = 0; t < ntiles; t++) {
            if ((ordered && run->plan.tiles[t].colour != c) || wpd_first_error_failed(&fe))
                continue;
            wpd_error local = {0};
            if (fn(run, t, inside, arg, &local))
                wpd_first_error_keep(&fe, &local);
            wpd_progress_add(run->opt->progress, 1);
        }
        wpd_error local = {0};
        if (!wpd_first_error_failed(&fe) && after_colour && after_colour(run, c, arg, &local))
            wpd_first_error_keep(&fe, &local);
    }
    if (phase)
        wpd_progress_end(run->opt->progress);
    return wpd_first_error_take(&fe, err);
}

int wpd_run_each_tile(wpd_run *run, const char *phase, wpd_tile_fn fn,
                      wpd_colour_fn after_colour, void *arg, wpd_error *err)
{
    return run_tiles(run, phase, fn, after_colour, arg, 1, err);
}

int wpd_run_tiles_any_order(wpd_run *run, const char *phase, wpd_tile_fn fn, void *arg,
                            wpd_error *err)
{
    return run_tiles(run, phase, fn, NULL, arg, 0, err);
}
