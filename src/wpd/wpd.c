/* wpd.c - the whole WPD pipeline on one in-memory block. */
#include "wpd/wpd.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/knn.h"
#include "core/sort.h"
#include "wpd/exact.h"
#include "wpd/poisson.h"
#include "wpd/radius.h"
#include "wpd/refine.h"
#include "wpd/sharp.h"
#include "wpd/smooth.h"

void wpd_params_default(wpd_params *p)
{
    memset(p, 0, sizeof *p);
    p->lambda = 0.68;
    p->voxel_frac = 0.05;
    p->radius_method = WPD_RADIUS_MULTISCALE;
    p->density = WPD_MULTISCALE_DENSITY;
    p->max_passes = 40;
    p->prune_previous = 0;
    p->k = 13;
    p->iterations = 5;
    p->smooth = 1;
    p->smooth_mode = WPD_SMOOTH_CENTROID;
    p->keep_on_surface = 1;
    p->sharp = 0;
    p->sharp_threshold = WPD_SHARP_THRESHOLD;
    p->seed = 0;
    p->threads = 0;
}

void wpd_result_free(wpd_result *res)
{
    free(res->gid);
    free(res->index);
    free(res->xyz);
    free(res->edge);
    memset(res, 0, sizeof *res);
}

static int check_args(const wpd_block *b, size_t target, const wpd_params *p, wpd_error *err)
{
    if (target < 1)
        return wpd_fail(err, WPD_E_USAGE, "wpd: target count must be at least 1");
    if (b->n > 0 && (!b->xyz || !b->gid))
        return wpd_fail(err, WPD_E_USAGE, "wpd: block of %zu points without coordinates or "
                        "global indices", b->n);
    if (b->n >= UINT32_MAX - 1)
        return wpd_fail(err, WPD_E_USAGE, "wpd: block of %zu points, at most %u per block",
                        b->n, UINT32_MAX - 2);
    if ((b->nfixed && !b->fixed_xyz) || (b->nctx && !b->ctx_xyz) || (b->nhalo && !b->halo_xyz))
        return wpd_fail(err, WPD_E_USAGE, "wpd: neighbour points counted but not given");
    if (!(p->lambda > 0) || !(p->voxel_frac > 0) || !(p->density > 0))
        return wpd_fail(err, WPD_E_USAGE, "wpd: lambda %g, voxel_frac %g and density %g must be "
                        "positive", p->lambda, p->voxel_frac, p->density);
    if (p->k < 3 || p->k > 64)
        return wpd_fail(err, WPD_E_USAGE, "wpd: k = %d neighbours, expected 3..64", p->k);
    if (p->smooth_mode < WPD_SMOOTH_CENTROID || p->smooth_mode > WPD_SMOOTH_COTAN)
        return wpd_fail(err, WPD_E_USAGE, "wpd: unknown smoothing mode %d", p->smooth_mode);
    if (p->iterations < 0)
        return wpd_fail(err, WPD_E_USAGE, "wpd: %d smoothing iterations", p->iterations);
    return 0;
}

static int finish_output(const wpd_block *b, const uint32_t *idx, size_t count,
                         const double *xyz, const uint8_t *edge, wpd_result *res,
                         wpd_error *err);

/* Every point, unchanged, in global index order: the target is not below
 * the block size. */
static int take_all(const wpd_block *b, wpd_result *res, wpd_error *err)
{
    uint32_t *idx = malloc((b->n ? b->n : 1) * sizeof *idx);
    if (!idx)
        return wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory for %zu points", b->n);
    for (size_t i = 0; i < b->n; i++)
        idx[i] = (uint32_t)i;
    int rc = finish_output(b, idx, b->n, b->xyz, NULL, res, err);
    free(idx);
    return rc;
}

/* Grid over the block points followed by the halo points. */
static int build_surface(const wpd_block *b, double cell, int k, int threads, wpd_grid *g,
                         wpd_error *err)
{
    if (b->nhalo == 0)
        return wpd_grid_build_knn(g, b->xyz, NULL, b->n, k, cell, threads, err);
    size_t total = b->n + b->nhalo;
    double *all = malloc(3 * total * sizeof *all);
    if (!all)
        return wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory for %zu surface points", total);
    memcpy(all, b->xyz, 3 * b->n * sizeof *all);
    memcpy(all + 3 * b->n, b->halo_xyz, 3 * b->nhalo * sizeof *all);
    int rc = wpd_grid_build_knn(g, all, NULL, total, k, cell, threads, err);
    free(all);
    return rc;
}

/* Poisson passes until the count is in [target, 1.05 target] (or the pass
 * budget runs out); the kept samples end in *out / *count.
 *
 * Passes over the full input share one prepared context, so a pass costs
 * only the greedy pruning. With p->prune_previous, a pass at a larger
 * radius than an overshooting one prunes that pass's samples instead (the
 * authors' release does this; it is cheaper per pass, but count against
 * radius is much steeper on an already spread-out sample, so the loop
 * tends to oscillate between pruned and full passes: measured 7-15 passes
 * instead of 2-3 on the NC Raleigh scan). */
static int poisson_refined(const wpd_block *b, const uint8_t *edge, size_t target,
                           const wpd_params *p, int threads, double r0, wpd_result *res,
                           uint32_t **out, size_t *count, wpd_error *err)
{
    size_t n = b->n;
    uint32_t *work = malloc(n * sizeof *work);
    uint32_t *super = NULL;
    size_t super_count = 0;
    if (!work)
        return wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory for %zu points", n);
    wpd_refine st;
    wpd_refine_init(&st, target, r0, p->max_passes);
    wpd_poisson_input in = {b->xyz, b->gid, edge, NULL, n, b->fixed_xyz, b->nfixed,
                            r0, p->seed, threads};
    wpd_poisson *full = wpd_poisson_prepare(&in, err);
    if (!full)
        goto fail;
    int prune = 0;
    for (;;) {
        long got;
        if (prune) {
            wpd_poisson_input sub = in;
            sub.cand = super;
            sub.ncand = super_count;
            sub.r = st.r;
            got = wpd_poisson_pass(&sub, work, err);
        } else {
            got = wpd_poisson_run(full, st.r, work, err);
        }
        if (got < 0)
            goto fail;
        if (st.passes == 0)
            res->first_pass_count = (size_t)got;
        wpd_refine_status status = wpd_refine_report(&st, (size_t)got);
        res->passes = st.passes;
        if (status == WPD_REFINE_AGAIN && (size_t)got > target && !p->prune_previous) {
            /* Overshoot: settled by pruning this pass (as the out-of-core
             * engine does), not by more passes over the input. */
            uint32_t *pruned = malloc((size_t)got * sizeof *pruned);
            long m = pruned ? wpd_prune_to_range(b->xyz, b->gid, work, (size_t)got, target,
                                                 st.last_r, p->seed, threads, pruned,
                                                 &res->radius, &res->prune_passes, err)
                            : wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory for %ld samples",
                                       got);
            if (m < 0) {
                free(pruned);
                goto fail;
            }
            *out = pruned;
            *count = (size_t)m;
            free(work);
            free(super);
            wpd_poisson_release(full);
            return 0;
        }
        if (status == WPD_REFINE_DONE || (status == WPD_REFINE_GAVE_UP && !super) ||
            (status == WPD_REFINE_GAVE_UP && st.superset_is_last)) {
            res->radius = st.last_r;
            *out = work;
            *count = (size_t)got;
            free(super);
            wpd_poisson_release(full);
            return 0;
        }
        if (status == WPD_REFINE_GAVE_UP) {
            res->radius = st.r_superset;
            *out = super;
            *count = super_count;
            free(work);
            wpd_poisson_release(full);
            return 0;
        }
        if (st.superset_is_last) { /* the latest overshoot: kept for pruning or giving up */
            uint32_t *keep = realloc(super, (size_t)got * sizeof *keep);
            if (!keep) {
                wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory for %zu samples", n);
                goto fail;
            }
            super = keep;
            memcpy(super, work, (size_t)got * sizeof *super);
            super_count = (size_t)got;
        }
        prune = p->prune_previous && wpd_refine_can_prune(&st);
    }
fail:
    wpd_poisson_release(full);
    free(work);
    free(super);
    return -1;
}

static int finish_output(const wpd_block *b, const uint32_t *idx, size_t count,
                         const double *xyz, const uint8_t *edge, wpd_result *res,
                         wpd_error *err)
{
    uint64_t *key = malloc((count ? count : 1) * sizeof *key);
    uint64_t *tk = malloc((count ? count : 1) * sizeof *tk);
    uint32_t *pos = malloc((count ? count : 1) * sizeof *pos);
    uint32_t *tv = malloc((count ? count : 1) * sizeof *tv);
    res->count = count;
    res->gid = malloc((count ? count : 1) * sizeof *res->gid);
    res->index = malloc((count ? count : 1) * sizeof *res->index);
    res->xyz = malloc((count ? 3 * count : 1) * sizeof *res->xyz);
    res->edge = edge ? malloc(count ? count : 1) : NULL;
    int rc = 0;
    if (!key || !tk || !pos || !tv || !res->gid || !res->index || !res->xyz || (edge && !res->edge)) {
        rc = wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory for %zu samples", count);
        goto done;
    }
    for (size_t i = 0; i < count; i++) {
        key[i] = b->gid[idx[i]];
        pos[i] = (uint32_t)i;
    }
    wpd_radix_sort_u64(key, pos, count, 64, tk, tv);
    for (size_t j = 0; j < count; j++) {
        size_t i = pos[j];
        res->gid[j] = key[j];
        res->index[j] = idx[i];
        memcpy(res->xyz + 3 * j, xyz + 3 * i, 3 * sizeof(double));
        if (edge)
            res->edge[j] = edge[i];
    }
done:
    free(key);
    free(tk);
    free(pos);
    free(tv);
    return rc;
}

int wpd_run_block(const wpd_block *b, size_t target, const wpd_params *p,
                  wpd_result *res, wpd_error *err)
{
    memset(res, 0, sizeof *res);
    if (check_args(b, target, p, err) < 0)
        return -1;
    double t_start = omp_get_wtime();
    int threads = p->threads > 0 ? p->threads : omp_get_max_threads();
    size_t n = b->n;
    if (n <= target) {
        int rc = take_all(b, res, err);
        if (rc < 0)
            wpd_result_free(res);
        else
            res->time.total = omp_get_wtime() - t_start;
        return rc;
    }

    uint8_t *edge = NULL, *sample_edge = NULL;
    uint32_t *idx = NULL;
    double *sxyz = NULL;
    wpd_grid surface = {0};
    size_t count = 0;
    int rc = -1;

    /* 1. radius */
    double t = omp_get_wtime();
    wpd_radius_info ri;
    if (p->radius > 0) {
        ri.radius = p->radius;
    } else if (p->radius_method == WPD_RADIUS_PAPER) {
        if (wpd_radius_paper(b->xyz, n, target, p->lambda, p->voxel_frac, threads, &ri, err) < 0)
            goto done;
    } else if (wpd_radius_multiscale(b->xyz, n, target, p->lambda, p->voxel_frac, p->density,
                                     threads, &ri, err) < 0) {
        goto done;
    }
    res->radius_estimate = ri.radius;
    res->time.radius = omp_get_wtime() - t;

    /* 2. A grid over the input points (and the halo) at about their k-th
     * neighbour distance, for sharp-feature detection and for keeping
     * smoothed samples on the surface. The input spacing is about
     * 1.5 r sqrt(target / n); 13 neighbours lie within ~1.7 spacings. */
    double input_dk = 2.5 * ri.radius * sqrt((double)target / (double)n);
    int want_surface = p->sharp || (p->smooth && p->keep_on_surface && p->iterations > 0);
    int surface_later = 0;
    if (p->sharp) {
        t = omp_get_wtime();
        if (build_surface(b, input_dk, p->k, threads, &surface, err) < 0)
            goto done;
        res->time.surface = omp_get_wtime() - t;
        t = omp_get_wtime();
        edge = malloc(n);
        if (!edge) {
            wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory for %zu edge labels", n);
            goto done;
        }
        wpd_detect_sharp(&surface, n, p->k, p->sharp_threshold, edge, threads);
        for (size_t i = 0; i < n; i++)
            res->sharp_points += edge[i];
        res->time.sharp = omp_get_wtime() - t;
    } else if (want_surface) {
        surface_later = 1;
    }

    /* 3. Poisson-disk passes with refinement. The greedy pass is sequential,
     * so with two or more threads the surface grid is built alongside it on
     * another thread (both results are independent of the threads). */
    t = omp_get_wtime();
    int poisson_rc = 0, surface_rc = 0;
    wpd_error surface_err;
    wpd_error_clear(&surface_err);
    if (surface_later && threads >= 2) {
#pragma omp parallel sections num_threads(2)
        {
#pragma omp section
            {
                poisson_rc = poisson_refined(b, edge, target, p, threads, ri.radius, res, &idx,
                                             &count, err);
                res->time.poisson = omp_get_wtime() - t;
            }
#pragma omp section
            {
                double ts = omp_get_wtime();
                surface_rc = build_surface(b, input_dk, p->k, 1, &surface, &surface_err);
                res->time.surface = omp_get_wtime() - ts;
            }
        }
    } else {
        poisson_rc = poisson_refined(b, edge, target, p, threads, ri.radius, res, &idx, &count,
                                     err);
        res->time.poisson = omp_get_wtime() - t;
        if (poisson_rc == 0 && surface_later) {
            double ts = omp_get_wtime();
            surface_rc = build_surface(b, input_dk, p->k, threads, &surface, &surface_err);
            res->time.surface = omp_get_wtime() - ts;
        }
    }
    if (poisson_rc < 0)
        goto done;
    if (surface_rc < 0) {
        *err = surface_err;
        goto done;
    }
    res->poisson_count = count;

    /* 4. exact count */
    t = omp_get_wtime();
    wpd_exact_input ex = {b->xyz, b->gid, b->fixed_xyz, b->nfixed, res->radius, threads};
    long kept = wpd_exact_count(&ex, idx, count, target, &res->exact_sweeps, err);
    if (kept < 0)
        goto done;
    count = (size_t)kept;
    res->time.exact = omp_get_wtime() - t;

    /* 5. smoothing */
    sxyz = malloc(3 * count * sizeof *sxyz);
    sample_edge = edge ? malloc(count) : NULL;
    if (!sxyz || (edge && !sample_edge)) {
        wpd_fail(err, WPD_E_MEMORY, "wpd: out of memory for %zu samples", count);
        goto done;
    }
    for (size_t i = 0; i < count; i++) {
        memcpy(sxyz + 3 * i, b->xyz + 3 * (size_t)idx[i], 3 * sizeof *sxyz);
        if (edge)
            sample_edge[i] = edge[idx[i]];
    }
    if (p->smooth && p->iterations > 0) {
        wpd_smooth_input sm = {sxyz, count, sample_edge, b->ctx_xyz, b->nctx,
                               p->keep_on_surface ? &surface : NULL, input_dk,
                               (wpd_smooth_mode)p->smooth_mode, p->k, p->iterations,
                               res->radius, threads,
                               {p->resolution[0], p->resolution[1], p->resolution[2]}};
        wpd_smooth_stats ss;
        if (wpd_smooth(&sm, &ss, err) < 0)
            goto done;
        res->open_cells = ss.open_cells;
        res->pulled_to_surface = ss.pulled_to_surface;
        res->time.normals = ss.normals_seconds;
        res->time.smooth = ss.smooth_seconds;
    }
    if (finish_output(b, idx, count, sxyz, sample_edge, res, err) < 0)
        goto done;
    rc = 0;
done:
    free(edge);
    free(sample_edge);
    free(idx);
    free(sxyz);
    wpd_grid_free(&surface);
    if (rc < 0) {
        wpd_result_free(res);
    } else {
        res->time.total = omp_get_wtime() - t_start;
    }
    return rc;
}
