/* synth_trees.c - the trees of `wpd synth`'s city: street trees along both
 * kerbs of every street and trees on a jittered grid in parks, each crown
 * an ellipsoid with a three-lobed outline drawn from the feature hash of
 * its slot (see synth_scene.h).
 */
#include "tools/synth/synth_scene.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#define TREE_SLOT 10.0          /* street tree spacing, park tree grid */

static void make_tree(const scene *sc, tree *t, const int64_t key[4], double cx, double cy,
                      double slack, int park)
{
    uint64_t h = feature_hash(sc->seed, 4, key[0], key[1], key[2] * 64 + key[3]);
    memcpy(t->key, key, sizeof t->key);
    t->valid = 1;
    t->present = hash_unit(h, 0) < (park ? 0.65 : 0.75);
    t->rh = park ? 2.4 + 1.6 * hash_unit(h, 1) : 2.0 + 1.7 * hash_unit(h, 1);
    t->rv = t->rh * (0.8 + 0.6 * hash_unit(h, 2));
    slack -= t->rh * 1.15;       /* keep the crown in its slot */
    if (slack > 0) {
        cx += slack * (2 * hash_unit(h, 3) - 1);
        cy += slack * (2 * hash_unit(h, 4) - 1);
    }
    t->cx = cx, t->cy = cy;
    t->zc = terrain(sc, cx, cy) + 2.0 + 3.0 * hash_unit(h, 5) + t->rv;
    t->lobe = 0.05 + 0.1 * hash_unit(h, 6);
    /* Outline orientation: cos/sin of the 6 angles 0, 20 .. 100 degrees
     * (the three lobes repeat every 120), without libm in this hot path. */
    static const double rot[6][2] = {
        {1, 0}, {0.9396926, 0.3420201}, {0.7660444, 0.6427876},
        {0.5, 0.8660254}, {0.1736482, 0.9848078}, {-0.1736482, 0.9848078}};
    int k = (int)(hash_unit(h, 7) * 6);
    t->rot_c = rot[k][0], t->rot_s = rot[k][1];
}

static const tree *cached_tree(const scene *sc, tree *cache, int64_t a, int64_t b, int64_t c,
                               int64_t d, double cx, double cy, double slack, int park)
{
    int64_t key[4] = {a, b, c, d};
    if (!cache->valid || memcmp(cache->key, key, sizeof key))
        make_tree(sc, cache, key, cx, cy, slack, park);
    return cache->present ? cache : NULL;
}

/* The street tree whose kerb line runs along axis 0 (x varies: u across the
 * street is p->v) or 1, near position (u across, v along) of a block; NULL if
 * none within reach. Block-local coordinates are mapped back to local x, y. */
static const tree *street_tree(const scene *sc, const block_pos *p, int axis, tree *cache)
{
    double across = axis ? p->u : p->v, along = axis ? p->v : p->u;
    int64_t bi = p->bi, bj = p->bj;
    /* Kerb lines at 2.5 and 13.5 in this period, and 2.5 of the next one. */
    double lines[3] = {KERB_OFFSET, STREET_WIDTH - KERB_OFFSET, BLOCK_PERIOD + KERB_OFFSET};
    int k = across < (lines[0] + lines[1]) / 2 ? 0 : across < (lines[1] + lines[2]) / 2 ? 1 : 2;
    if (fabs(across - lines[k]) > TREE_MAX_REACH || along < STREET_WIDTH)
        return NULL;
    int slot = (int)((along - STREET_WIDTH) / TREE_SLOT);
    double line = lines[k];
    if (k == 2) {                /* the next period's first line */
        line = KERB_OFFSET, k = 0;
        if (axis) bi++; else bj++;
    }
    double base_x = sc->grid0 + bi * BLOCK_PERIOD, base_y = sc->grid0 + bj * BLOCK_PERIOD;
    double c_along = STREET_WIDTH + (slot + 0.5) * TREE_SLOT;
    double cx = base_x + (axis ? line : c_along), cy = base_y + (axis ? c_along : line);
    /* Street trees are planted on a regular line: no jitter. */
    return cached_tree(sc, cache, bi, bj, axis * 2 + k, slot, cx, cy, 0, 0);
}

static const tree *park_tree(const scene *sc, const block_pos *p, tree *cache)
{
    int ci = (int)((p->u - STREET_WIDTH) / TREE_SLOT), cj = (int)((p->v - STREET_WIDTH) / TREE_SLOT);
    double cx = sc->grid0 + p->bi * BLOCK_PERIOD + STREET_WIDTH + (ci + 0.5) * TREE_SLOT;
    double cy = sc->grid0 + p->bj * BLOCK_PERIOD + STREET_WIDTH + (cj + 0.5) * TREE_SLOT;
    return cached_tree(sc, cache, p->bi, p->bj, 8, ci * 16 + cj, cx, cy, TREE_SLOT / 2, 1);
}

static inline double dist2(double x, double y, const tree *t)
{
    return (x - t->cx) * (x - t->cx) + (y - t->cy) * (y - t->cy);
}

static const tree *nearer(double x, double y, const tree *a, const tree *b)
{
    if (!a || !b)
        return a ? a : b;
    return dist2(x, y, a) <= dist2(x, y, b) ? a : b;
}

/* The tree whose crown may cover (x, y): the nearest of the park tree of
 * the cell and the street trees of the two kerb directions that can reach
 * it. caches[0..2] are per kind (two kerb directions, park). */
const tree *synth_tree_at(const scene *sc, double x, double y, block_info *blocks,
                          tree caches[3])
{
    block_pos p = locate(sc, x, y);
    const tree *t = NULL;
    if (p.u >= STREET_WIDTH && p.v >= STREET_WIDTH &&
        synth_block_at(sc, blocks, p.bi, p.bj)->park)
        t = park_tree(sc, &p, &caches[2]);
    const double reach_in = TREE_MAX_REACH - KERB_OFFSET;   /* street crowns into a block */
    if (p.u >= STREET_WIDTH + reach_in && p.v >= STREET_WIDTH + reach_in &&
        p.u <= BLOCK_PERIOD - reach_in && p.v <= BLOCK_PERIOD - reach_in)
        return t;                /* inside a block, out of the street trees' reach */
    t = nearer(x, y, t, street_tree(sc, &p, 1, &caches[0]));
    return nearer(x, y, t, street_tree(sc, &p, 0, &caches[1]));
}
