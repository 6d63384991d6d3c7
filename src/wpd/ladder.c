#include "wpd/ladder.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* Keys pack 21 bits per axis of voxel indices relative to the origin. */
enum { KEY_BITS = 21 };
#define KEY_MASK ((1ull << KEY_BITS) - 1)

static uint64_t pack(uint64_t ix, uint64_t iy, uint64_t iz)
{
    return ix | iy << KEY_BITS | iz << (2 * KEY_BITS);
}

/* The key of the voxel twice as large that contains voxel key. */
static uint64_t coarser(uint64_t key)
{
    return pack((key & KEY_MASK) >> 1, ((key >> KEY_BITS) & KEY_MASK) >> 1,
                (key >> (2 * KEY_BITS)) >> 1);
}

/* Replaces set by the set of its voxels' parents. */
static int coarsen(wpd_voxel_set *set)
{
    wpd_voxel_set next;
    size_t cap = 1024;
    while (cap < set->count)
        cap <<= 1;
    if (wpd_voxel_set_init(&next, cap) < 0)
        return -1;
    for (size_t i = 0; i < set->cap; i++)
        if (set->slot[i] != WPD_VOXEL_KEY_EMPTY && wpd_voxel_set_put(&next, coarser(set->slot[i]))) {
            wpd_voxel_set_free(&next);
            return -1;
        }
    wpd_voxel_set_free(set);
    *set = next;
    return 0;
}

/* One scale coarser: every key and the edge. */
static int coarsen_ladder(wpd_ladder *l)
{
    if (coarsen(&l->set))
        return -1;
    l->edge *= 2;
    l->inv = 1.0 / l->edge;
    l->level++;
    l->last = WPD_VOXEL_KEY_EMPTY;
    return 0;
}

/* Coarsens until the keys fit the cap. */
static int fit_cap(wpd_ladder *l)
{
    while (l->set.count > l->cap)
        if (coarsen_ladder(l))
            return -1;
    return 0;
}

int wpd_ladder_init(wpd_ladder *l, const double extent[3], uint64_t npoints, size_t cap)
{
    memset(l, 0, sizeof *l);
    l->cap = cap < 1024 ? 1024 : cap;
    l->last = WPD_VOXEL_KEY_EMPTY;
    /* Starting finer than needed only costs cache misses (2^16 voxels along
     * the NC Raleigh scan cost 1.3 s); never finer than 2^16 along the
     * longest axis, so indices fit their 21 bits. */
    double longest = fmax(extent[0], fmax(extent[1], extent[2]));
    double face = fmax(extent[0] * extent[1], fmax(extent[0] * extent[2], extent[1] * extent[2]));
    double keys = fmin((double)l->cap / 2, (double)npoints);
    l->edge = fmax(longest / 65536.0, sqrt(face / fmax(keys, 1)));
    if (!(l->edge > 0))
        l->edge = 1.0;
    l->inv = 1.0 / l->edge;
    return wpd_voxel_set_init(&l->set, 4096);
}

int wpd_ladder_put(wpd_ladder *l, const double p[3])
{
    uint64_t key = pack((uint64_t)(p[0] * l->inv) & KEY_MASK, (uint64_t)(p[1] * l->inv) & KEY_MASK,
                        (uint64_t)(p[2] * l->inv) & KEY_MASK);
    if (key == l->last)
        return 0;
    l->last = key;
    if (wpd_voxel_set_put(&l->set, key))
        return -1;
    return fit_cap(l);
}

int wpd_ladder_merge(wpd_ladder *into, wpd_ladder *from)
{
    while (into->level < from->level)
        if (coarsen_ladder(into))
            return -1;
    while (from->level < into->level)
        if (coarsen_ladder(from))
            return -1;
    for (size_t i = 0; i < from->set.cap; i++) {
        uint64_t key = from->set.slot[i];
        if (key == WPD_VOXEL_KEY_EMPTY)
            continue;
        /* into may have coarsened during the merge: bring key along */
        for (int d = from->level; d < into->level; d++)
            key = coarser(key);
        if (wpd_voxel_set_put(&into->set, key) || fit_cap(into))
            return -1;
    }
    into->last = WPD_VOXEL_KEY_EMPTY;
    return 0;
}

int wpd_ladder_finish(wpd_ladder *l, double *edge, uint64_t *m, int *nscales)
{
    *nscales = 0;
    double e = l->edge;
    while (*nscales < WPD_MAX_SCALES) {
        edge[*nscales] = e;
        m[*nscales] = l->set.count;
        (*nscales)++;
        if (l->set.count <= 1)
            break;
        if (coarsen(&l->set))
            return -1;
        e *= 2;
    }
    return 0;
}

void wpd_ladder_free(wpd_ladder *l)
{
    wpd_voxel_set_free(&l->set);
}

double wpd_ladder_radius(const double *xyz, size_t n, const double extent[3], size_t target,
                         double density, int threads)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
    wpd_ladder *part = calloc((size_t)threads, sizeof *part);
    if (!part)
        return -1;
    double edge[WPD_MAX_SCALES];
    uint64_t m[WPD_MAX_SCALES];
    int nscales = 0, rc = 0;
    /* Each thread counts a contiguous share; the merge gives what one
     * stream over all points gives (wpd_ladder_merge). */
#pragma omp parallel num_threads(threads) reduction(| : rc)
    {
        int t = omp_get_thread_num(), nt = omp_get_num_threads();
        size_t lo = n * (size_t)t / (size_t)nt, hi = n * (size_t)(t + 1) / (size_t)nt;
        rc |= wpd_ladder_init(&part[t], extent, n, WPD_LADDER_KEYS);
        for (size_t i = lo; rc == 0 && i < hi; i++)
            rc |= wpd_ladder_put(&part[t], xyz + 3 * i);
    }
    for (int t = 1; rc == 0 && t < threads; t++)
        if (part[t].set.slot) /* NULL: the team had fewer threads */
            rc = wpd_ladder_merge(&part[0], &part[t]);
    if (rc == 0)
        rc = wpd_ladder_finish(&part[0], edge, m, &nscales);
    for (int t = 0; t < threads; t++)
        wpd_ladder_free(&part[t]);
    free(part);
    if (rc)
        return -1;
    wpd_radius_info ri;
    wpd_radius_from_counts(edge, m, nscales, target, density, &ri);
    return ri.radius;
}
