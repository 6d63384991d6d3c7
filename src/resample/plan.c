#include "resample/plan.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* 3-D prefix sums of the density grid: box counts in O(1). */
typedef struct prefix {
    int dim[3];
    uint64_t *sum;             /* [(d0+1)(d1+1)(d2+1)] */
} prefix;

static size_t pidx(const prefix *p, int x, int y, int z)
{
    return (size_t)x + (size_t)(p->dim[0] + 1) * ((size_t)y + (size_t)(p->dim[1] + 1) * z);
}

static int prefix_build(prefix *p, const wpd_scan *s)
{
    memcpy(p->dim, s->dim, sizeof p->dim);
    p->sum = calloc((size_t)(s->dim[0] + 1) * (s->dim[1] + 1) * (s->dim[2] + 1), sizeof *p->sum);
    if (!p->sum)
        return -1;
    for (int z = 1; z <= s->dim[2]; z++)
        for (int y = 1; y <= s->dim[1]; y++)
            for (int x = 1; x <= s->dim[0]; x++) {
                uint64_t c = s->density[(size_t)(x - 1) +
                                        (size_t)s->dim[0] * ((size_t)(y - 1) +
                                                             (size_t)s->dim[1] * (z - 1))];
                p->sum[pidx(p, x, y, z)] =
                    c + p->sum[pidx(p, x - 1, y, z)] + p->sum[pidx(p, x, y - 1, z)] +
                    p->sum[pidx(p, x, y, z - 1)] - p->sum[pidx(p, x - 1, y - 1, z)] -
                    p->sum[pidx(p, x - 1, y, z - 1)] - p->sum[pidx(p, x, y - 1, z - 1)] +
                    p->sum[pidx(p, x - 1, y - 1, z - 1)];
            }
    return 0;
}

static uint64_t box_count(const prefix *p, const int lo[3], const int hi[3])
{
    return p->sum[pidx(p, hi[0], hi[1], hi[2])] - p->sum[pidx(p, lo[0], hi[1], hi[2])] -
           p->sum[pidx(p, hi[0], lo[1], hi[2])] - p->sum[pidx(p, hi[0], hi[1], lo[2])] +
           p->sum[pidx(p, lo[0], lo[1], hi[2])] + p->sum[pidx(p, lo[0], hi[1], lo[2])] +
           p->sum[pidx(p, hi[0], lo[1], lo[2])] - p->sum[pidx(p, lo[0], lo[1], lo[2])];
}

/* Splits tile t across its longest side (in cells) at the median point
 * count into t and a new tile n. Returns 0, or -1 if t is a single cell. */
static int split_tile(const prefix *p, wpd_tile *t, wpd_tile *n)
{
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (t->hi[a] - t->lo[a] > t->hi[axis] - t->lo[axis])
            axis = a;
    if (t->hi[axis] - t->lo[axis] < 2)
        return -1;
    int lo[3], hi[3];
    memcpy(lo, t->lo, sizeof lo);
    memcpy(hi, t->hi, sizeof hi);
    int cut = t->lo[axis] + 1;
    for (; cut < t->hi[axis] - 1; cut++) {
        hi[axis] = cut;
        if (2 * box_count(p, lo, hi) >= t->points)
            break;
    }
    *n = *t;
    t->hi[axis] = cut;
    n->lo[axis] = cut;
    t->points = box_count(p, t->lo, t->hi);
    n->points = box_count(p, n->lo, n->hi);
    return 0;
}

/* Points a tile reads beyond its own: those within the halo outside its
 * faces, from the density grid - the slab of whole cells along each face,
 * scaled by the halo's share of the slab's width (cells are usually wider
 * than the halo). At a large radius (a small n) the halo adds an eighth to
 * a tile, and a tile's memory goes with the points it reads. */
static uint64_t halo_points(const prefix *p, const wpd_tile *t, double halo_cells)
{
    int w = (int)ceil(halo_cells);
    if (w < 1)
        return 0;
    double share = halo_cells / w, sum = 0;
    for (int a = 0; a < 3; a++)
        for (int side = 0; side < 2; side++) {
            int lo[3], hi[3];
            memcpy(lo, t->lo, sizeof lo);
            memcpy(hi, t->hi, sizeof hi);
            if (side == 0) {
                hi[a] = t->lo[a];
                lo[a] = t->lo[a] > w ? t->lo[a] - w : 0;
            } else {
                lo[a] = t->hi[a];
                hi[a] = t->hi[a] + w < p->dim[a] ? t->hi[a] + w : p->dim[a];
            }
            if (lo[a] < hi[a])
                sum += share * (double)box_count(p, lo, hi);
        }
    return (uint64_t)sum;
}

/* Index of the tile to split next: the most points read (own and halo)
 * among splittable tiles that must be split, -1 when none. A tile whose
 * own points are half the limit is not split for its halo: halving it
 * would hardly shrink the halo (tiny tiles under a tight budget). */
static int next_to_split(const wpd_tile *tiles, const uint64_t *load, int n,
                         const uint8_t *stuck, uint64_t max_points, int min_tiles)
{
    int best = -1;
    for (int i = 0; i < n; i++)
        if (!stuck[i] &&
            ((load[i] > max_points && 2 * tiles[i].points > max_points) || n < min_tiles) &&
            (best < 0 || load[i] > load[best]))
            best = i;
    return best;
}

static int cut_tiles(const wpd_scan *s, const prefix *p, uint64_t max_points, int min_tiles,
                     double halo, wpd_plan *out)
{
    int cap = 64, n = 1;
    double halo_cells = halo / s->cell;
    wpd_tile *tiles = calloc((size_t)cap, sizeof *tiles);
    uint64_t *load = calloc((size_t)cap, sizeof *load);
    uint8_t *stuck = calloc((size_t)cap, 1);
    if (!tiles || !load || !stuck)
        goto fail;
    memcpy(tiles[0].hi, s->dim, sizeof tiles[0].hi);
    tiles[0].points = load[0] = s->count;
    for (int i; (i = next_to_split(tiles, load, n, stuck, max_points, min_tiles)) >= 0;) {
        if (n == cap) {
            cap *= 2;
            wpd_tile *t = realloc(tiles, (size_t)cap * sizeof *t);
            if (t)
                tiles = t;
            uint64_t *l = realloc(load, (size_t)cap * sizeof *l);
            if (l)
                load = l;
            uint8_t *st = realloc(stuck, (size_t)cap);
            if (st)
                stuck = st;
            if (!t || !l || !st)
                goto fail;
            memset(stuck + n, 0, (size_t)(cap - n));
        }
        if (split_tile(p, &tiles[i], &tiles[n]) < 0) {
            stuck[i] = 1;
            continue;
        }
        load[i] = tiles[i].points + halo_points(p, &tiles[i], halo_cells);
        load[n] = tiles[n].points + halo_points(p, &tiles[n], halo_cells);
        n++;
    }
    free(load);
    free(stuck);
    out->tiles = tiles;
    out->ntiles = n;
    return 0;
fail:
    free(tiles);
    free(load);
    free(stuck);
    return -1;
}

static int boxes_near(const wpd_tile *a, const wpd_tile *b, double halo)
{
    for (int k = 0; k < 3; k++)
        if (a->box_lo[k] > b->box_hi[k] + halo || b->box_lo[k] > a->box_hi[k] + halo)
            return 0;
    return 1;
}

/* Boxes in frame coordinates; the outer faces extend to infinity so that
 * every point (also one rounded past the last cell) has a home tile. */
static void set_boxes(const wpd_scan *s, wpd_plan *pl)
{
    for (int i = 0; i < pl->ntiles; i++) {
        wpd_tile *t = &pl->tiles[i];
        for (int a = 0; a < 3; a++) {
            t->box_lo[a] = t->lo[a] == 0 ? -INFINITY : t->lo[a] * s->cell;
            t->box_hi[a] = t->hi[a] == s->dim[a] ? INFINITY : t->hi[a] * s->cell;
        }
    }
}

static int link_and_colour(wpd_plan *pl)
{
    int n = pl->ntiles;
    int *buf = malloc((size_t)n * sizeof *buf);
    uint8_t *used = malloc((size_t)n + 1);
    if (!buf || !used) {
        free(buf);
        free(used);
        return -1;
    }
    pl->ncolours = 0;
    for (int i = 0; i < n; i++) {
        wpd_tile *t = &pl->tiles[i];
        t->nadj = 0;
        for (int j = 0; j < n; j++)
            if (j != i && boxes_near(t, &pl->tiles[j], pl->halo))
                buf[t->nadj++] = j;
        t->adj = malloc((size_t)(t->nadj ? t->nadj : 1) * sizeof *t->adj);
        if (!t->adj) {
            free(buf);
            free(used);
            return -1;
        }
        memcpy(t->adj, buf, (size_t)t->nadj * sizeof *t->adj);
        memset(used, 0, (size_t)n + 1);
        for (int j = 0; j < t->nadj; j++)
            if (t->adj[j] < i)
                used[pl->tiles[t->adj[j]].colour] = 1;
        t->colour = 0;
        while (used[t->colour])
            t->colour++;
        if (t->colour + 1 > pl->ncolours)
            pl->ncolours = t->colour + 1;
    }
    free(buf);
    free(used);
    return 0;
}

static void map_cells(const wpd_scan *s, wpd_plan *pl)
{
    for (int i = 0; i < pl->ntiles; i++) {
        const wpd_tile *t = &pl->tiles[i];
        for (int z = t->lo[2]; z < t->hi[2]; z++)
            for (int y = t->lo[1]; y < t->hi[1]; y++)
                for (int x = t->lo[0]; x < t->hi[0]; x++)
                    pl->cell_tile[(size_t)x + (size_t)s->dim[0] * ((size_t)y + (size_t)s->dim[1] * z)] = i;
        if (t->points > pl->largest)
            pl->largest = t->points;
    }
}

int wpd_plan_tiles(const wpd_scan *scan, uint64_t max_points, int min_tiles, double halo,
                   wpd_plan *out, wpd_error *err)
{
    memset(out, 0, sizeof *out);
    out->halo = halo;
    prefix p = {{0, 0, 0}, NULL};
    size_t cells = (size_t)scan->dim[0] * scan->dim[1] * scan->dim[2];
    out->cell_tile = malloc(cells * sizeof *out->cell_tile);
    int failed = !out->cell_tile || prefix_build(&p, scan) ||
                 cut_tiles(scan, &p, max_points, min_tiles, halo, out);
    if (!failed) {
        set_boxes(scan, out);
        failed = link_and_colour(out);
    }
    free(p.sum);
    if (failed) {
        wpd_plan_free(out);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory planning tiles");
    }
    map_cells(scan, out);
    if (out->largest > 2 * max_points) {
        wpd_fail(err, WPD_E_MEMORY,
                 "memory budget too small: %llu points fall in one %.3g-unit cell and a tile "
                 "may hold %llu (raise --mem)", (unsigned long long)out->largest, scan->cell,
                 (unsigned long long)max_points);
        wpd_plan_free(out);
        return -1;
    }
    return 0;
}

void wpd_plan_free(wpd_plan *p)
{
    for (int i = 0; p->tiles && i < p->ntiles; i++)
        free(p->tiles[i].adj);
    free(p->tiles);
    free(p->cell_tile);
    memset(p, 0, sizeof *p);
}
