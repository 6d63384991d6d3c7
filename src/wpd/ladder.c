#include "wpd/ladder.h"

#include <math.h>
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
