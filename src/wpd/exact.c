/* exact.c - deletion by smallest nearest-neighbour distance. */
#include "wpd/exact.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/knn.h"

int wpd_nearest_distances(const wpd_exact_input *in, const uint32_t *idx, size_t count,
                          double *nn, uint32_t *partner, wpd_error *err)
{
    int threads = in->threads > 0 ? in->threads : omp_get_max_threads();
    wpd_grid g = {0}, gf = {0};
    /* Cells of about the nearest-neighbour distance. */
    double cell = in->spacing > 0 ? 1.5 * in->spacing : 1;
    if (wpd_grid_build_knn(&g, in->xyz, idx, count, 1, cell, threads, err) < 0)
        return -1;
    cell = g.cell;
    if (in->nfixed && wpd_grid_build(&gf, in->fixed_xyz, NULL, in->nfixed, cell, threads, err) < 0) {
        wpd_grid_free(&g);
        return -1;
    }
#pragma omp parallel num_threads(threads)
    {
        /* Poisson samples are about `spacing` apart; then the distance of
         * the previous query (speed only, never the answer). */
        double hint = 1.5 * in->spacing;
#pragma omp for schedule(dynamic, 512)
        for (size_t i = 0; i < count; i++) {
            const double *p = in->xyz + 3 * (size_t)idx[i];
            uint32_t who, fwho;
            double d2 = INFINITY, f2 = INFINITY;
            if (wpd_knn(&g, p, 1, idx[i], INFINITY, hint, &who, &d2) < 1)
                d2 = INFINITY;
            if (in->nfixed && wpd_knn(&gf, p, 1, WPD_NO_SELF, INFINITY, hint, &fwho, &f2) < 1)
                f2 = INFINITY;
            if (isfinite(d2))
                hint = 1.5 * sqrt(d2);
            uint32_t pos = UINT32_MAX;
            if (d2 <= f2 && isfinite(d2)) { /* idx is ascending: binary search */
                size_t lo = 0, hi = count;
                while (lo < hi) {
                    size_t mid = (lo + hi) / 2;
                    if (idx[mid] < who)
                        lo = mid + 1;
                    else
                        hi = mid;
                }
                pos = (uint32_t)lo;
            }
            nn[i] = sqrt(d2 <= f2 ? d2 : f2);
            if (partner)
                partner[i] = pos;
        }
    }
    wpd_grid_free(&g);
    wpd_grid_free(&gf);
    return 0;
}

typedef struct ranked {
    double d;
    uint64_t gid;
    uint32_t pos;
} ranked;

static int cmp_ranked(const void *a, const void *b)
{
    const ranked *x = a, *y = b;
    if (x->d != y->d)
        return x->d < y->d ? -1 : 1;
    return (x->gid > y->gid) - (x->gid < y->gid);
}

long wpd_exact_count(const wpd_exact_input *in, uint32_t *idx, size_t count, size_t target,
                     int *sweeps, wpd_error *err)
{
    if (sweeps)
        *sweeps = 0;
    if (count <= target)
        return (long)count;
    double *nn = malloc(count * sizeof *nn);
    uint32_t *partner = malloc(count * sizeof *partner);
    ranked *order = malloc(count * sizeof *order);
    uint8_t *gone = malloc(count);
    if (!nn || !partner || !order || !gone) {
        free(nn);
        free(partner);
        free(order);
        free(gone);
        return wpd_fail(err, WPD_E_MEMORY, "exact count: out of memory for %zu samples", count);
    }
    wpd_exact_input sweep_in = *in;
    while (count > target) {
        if (wpd_nearest_distances(&sweep_in, idx, count, nn, partner, err) < 0) {
            count = (size_t)-1;
            break;
        }
        if (sweeps)
            (*sweeps)++;
        for (size_t i = 0; i < count; i++) {
            order[i].d = nn[i];
            order[i].gid = in->gid[idx[i]];
            order[i].pos = (uint32_t)i;
        }
        qsort(order, count, sizeof *order, cmp_ranked);
        memset(gone, 0, count);
        size_t left = count;
        for (size_t k = 0; k < count && left > target; k++) {
            uint32_t i = order[k].pos;
            if (partner[i] != UINT32_MAX && gone[partner[i]])
                continue;
            gone[i] = 1;
            left--;
        }
        size_t w = 0;
        for (size_t i = 0; i < count; i++)
            if (!gone[i])
                idx[w++] = idx[i];
        count = w;
        /* Survivors are farther apart now: coarser cells for the next sweep. */
        double median = order[count / 2].d;
        if (isfinite(median) && median > sweep_in.spacing)
            sweep_in.spacing = median;
    }
    free(nn);
    free(partner);
    free(order);
    free(gone);
    return (long)count;
}
