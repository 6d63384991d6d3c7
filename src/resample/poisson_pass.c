/* poisson_pass.c - the Poisson-disk passes over the tiles with the paper's
 * count refinement (an overshoot is pruned over all samples, flat.c), and
 * the take-everything run for n >= the input. */
#include "resample/run.h"

#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/knn.h"
#include "wpd/refine.h"
#include "wpd/sharp.h"

/* What a pass shares between its tiles. */
typedef struct pass_ctx {
    double r;
    wpd_poisson *memo;        /* one in-memory tile: grid and priorities prepared
                                 once for every pass */
    uint8_t *memo_edge;       /* and its sharp labels (the context borrows them) */
} pass_ctx;

/* Sharp-feature labels of every point of d (own and halo): the surface
 * variation of each point's k nearest points among d's. */
static int label_sharp(const wpd_run *run, const wpd_tile_data *d, int threads, uint8_t **edge,
                       wpd_error *err)
{
    wpd_grid surface = {0};
    *edge = malloc(d->n ? d->n : 1);
    if (!*edge)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu edge labels", d->n);
    if (wpd_grid_build_knn(&surface, d->xyz, NULL, d->n, run->p->k, run->surface_dk, threads,
                           err))
        return -1;
    wpd_detect_sharp(&surface, d->n, run->p->k, run->p->sharp_threshold, *edge, threads);
    wpd_grid_free(&surface);
    return 0;
}

/* Candidates of tile t: its own points, and the halo points of neighbours
 * not yet processed (later colours). The greedy pass over both decides the
 * border points as the pass over the whole cloud would - a point is kept
 * iff no kept point of smaller priority lies within r, and the halo holds
 * the points that decide that. Halo points of finished neighbours are
 * settled: their samples are fixed, the rest are gone. */
static size_t candidates(const wpd_run *run, int t, const wpd_tile_data *d, uint32_t *cand)
{
    size_t ncand = 0;
    int colour = run->plan.tiles[t].colour;
    for (size_t i = 0; i < d->n; i++) {
        int home = d->halo[i] ? run->plan.cell_tile[wpd_scan_cell_of(&run->scan, d->xyz + 3 * i)]
                              : t;
        if (home == t || run->plan.tiles[home].colour > colour)
            cand[ncand++] = (uint32_t)i;
    }
    return ncand;
}

/* Keeps the own points among kept[0..m-1] of d as tile t's samples. */
static int keep_own(wpd_run *run, int t, const wpd_tile_data *d, const uint8_t *edge,
                    const uint32_t *kept, size_t m)
{
    size_t own = 0;
    for (size_t i = 0; i < m; i++)
        own += !d->halo[kept[i]];
    wpd_tile_samples *s = &run->store[t];
    if (wpd_samples_alloc(s, own, edge != NULL))
        return -1;
    for (size_t i = 0; i < m; i++) {
        uint32_t k = kept[i];
        if (d->halo[k])
            continue;
        s->gid[s->n] = d->gid[k];
        memcpy(s->xyz + 3 * s->n, d->xyz + 3 * (size_t)k, 3 * sizeof *s->xyz);
        if (edge)
            s->edge[s->n] = edge[k];
        s->n++;
    }
    return 0;
}

static long run_pass(wpd_run *run, int t, int threads, pass_ctx *pc, const wpd_tile_data *d,
                     const uint8_t *edge, uint32_t *cand, uint32_t *kept, wpd_error *err)
{
    const wpd_params *p = run->p;
    if (run->plan.ntiles == 1) { /* no halo, no neighbour: every point a candidate */
        if (!pc->memo) {
            wpd_poisson_input in = {d->xyz, d->gid, edge, NULL, d->n, NULL, 0, pc->r, p->seed,
                                    threads};
            if (!(pc->memo = wpd_poisson_prepare(&in, err)))
                return -1;
        }
        return wpd_poisson_run(pc->memo, pc->r, kept, err);
    }
    double *fixed = NULL;
    size_t nfixed = 0;
    if (wpd_run_neighbour_samples(run, t, run->halo + pc->r, &fixed, &nfixed))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
    size_t ncand = candidates(run, t, d, cand);
    wpd_poisson_input in = {d->xyz, d->gid, edge, cand, ncand, fixed, nfixed, pc->r, p->seed,
                            threads};
    long m = wpd_poisson_pass(&in, kept, err);
    free(fixed);
    return m;
}

/* One tile of a pass at radius pc->r. */
static int poisson_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    pass_ctx *pc = arg;
    wpd_tile_data d;
    if (wpd_tiles_read(&run->tiles, t, &d, err))
        return -1;
    uint32_t *cand = malloc((d.n ? d.n : 1) * sizeof *cand);
    uint32_t *kept = malloc((d.n ? d.n : 1) * sizeof *kept);
    uint8_t *edge = NULL;
    int rc = -1;
    if (!cand || !kept) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
        goto done;
    }
    if (run->p->sharp && pc->memo_edge) {
        edge = pc->memo_edge;
    } else if (run->p->sharp) {
        if (label_sharp(run, &d, threads, &edge, err))
            goto done;
        if (run->plan.ntiles == 1)
            pc->memo_edge = edge;
    }
    long m = run_pass(run, t, threads, pc, &d, edge, cand, kept, err);
    if (m < 0)
        goto done;
    if (keep_own(run, t, &d, edge, kept, (size_t)m)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
        goto done;
    }
    if (edge && run->res->passes == 0) {
        uint64_t sharp = 0;
        for (size_t i = 0; i < d.n; i++)
            sharp += edge[i] && !d.halo[i];
#pragma omp atomic
        run->res->sharp_points += sharp;
    }
    rc = 0;
done:
    free(cand);
    free(kept);
    if (edge != pc->memo_edge)
        free(edge);
    wpd_tiles_release(&run->tiles, &d);
    return rc;
}

static int full_pass(wpd_run *run, pass_ctx *pc, size_t *count, wpd_error *err)
{
    wpd_run_store_clear(run);
    if (wpd_run_each_tile(run, "poisson", poisson_tile, pc, err))
        return -1;
    *count = wpd_run_store_count(run);
    run->res->passes++;
    return 0;
}

/* Full passes with the paper's refinement until the count reaches
 * [n, 1.05 n], or overshoots: the overshoot is then pruned over all
 * samples (wpd_prune_phase). */
int wpd_poisson_phase(wpd_run *run, wpd_error *err)
{
    size_t n = run->opt->target, count = 0;
    wpd_refine st;
    wpd_refine_init(&st, n, run->res->radius_estimate, run->p->max_passes);
    pass_ctx pc = {0};
    int rc = -1;
    for (;;) {
        pc.r = st.r;
        if (full_pass(run, &pc, &count, err))
            break;
        if (run->res->passes == 1)
            run->res->first_pass_count = count;
        run->res->radius = pc.r;
        wpd_refine_status s = wpd_refine_report(&st, count);
        if (s == WPD_REFINE_DONE || (s == WPD_REFINE_GAVE_UP && count <= n)) {
            rc = 0;
            break;
        }
        if (count > n) {
            wpd_poisson_release(pc.memo); /* the pruning's peak is next */
            pc.memo = NULL;
            rc = wpd_prune_phase(run, pc.r, err);
            break;
        }
    }
    wpd_poisson_release(pc.memo);
    free(pc.memo_edge);
    run->res->poisson_count = wpd_run_store_count(run);
    return rc;
}

/* n >= the input: every own point is kept as it is. */
static int take_all_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    (void)threads, (void)arg;
    wpd_tile_data d;
    if (wpd_tiles_read(&run->tiles, t, &d, err))
        return -1;
    uint32_t *own = malloc((d.n ? d.n : 1) * sizeof *own);
    size_t m = 0;
    for (size_t i = 0; own && i < d.n; i++)
        if (!d.halo[i])
            own[m++] = (uint32_t)i;
    int rc = own && keep_own(run, t, &d, NULL, own, m) == 0
                 ? 0
                 : wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
    free(own);
    wpd_tiles_release(&run->tiles, &d);
    return rc;
}

int wpd_take_all_phase(wpd_run *run, wpd_error *err)
{
    return wpd_run_each_tile(run, NULL, take_all_tile, NULL, err);
}
