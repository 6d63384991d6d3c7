/* plan.h - cutting the cloud into tiles that fit the memory budget.
 *
 * Tiles are boxes of density-grid cells (the scan's coarse voxels), found
 * by splitting the whole grid kd-tree style - the tile that reads the most
 * points is split across its longest side at its median - until every tile
 * reads at most max_points, its own and those within the halo outside its
 * faces (estimated from the grid), and there are at least min_tiles. Two
 * tiles are
 * neighbours when their boxes come within the halo width of each other; a
 * greedy colouring in tile order gives neighbours different colours, so the
 * tiles of one colour can be processed at the same time while each sees
 * the finished work of its neighbours of earlier colours.
 */
#ifndef WPD_PLAN_H
#define WPD_PLAN_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "resample/scan.h"

typedef struct wpd_tile {
    int lo[3], hi[3];          /* grid cells [lo, hi) per axis */
    double box_lo[3], box_hi[3]; /* frame coordinates of the box */
    uint64_t points;           /* home points */
    int colour;
    int nadj;                  /* neighbouring tiles */
    int *adj;                  /* [nadj], ascending */
} wpd_tile;

typedef struct wpd_plan {
    int ntiles;
    wpd_tile *tiles;
    int ncolours;
    int *cell_tile;            /* [cells] tile of each density-grid cell */
    double halo;               /* halo width */
    uint64_t largest;          /* points of the largest tile */
} wpd_plan;

/* Plans tiles over scan's density grid. Returns 0, or -1 with err set
 * (WPD_E_MEMORY, also when one grid cell alone holds more than 2 x
 * max_points: the budget is then too small for this cloud). */
int wpd_plan_tiles(const wpd_scan *scan, uint64_t max_points, int min_tiles, double halo,
                   wpd_plan *out, wpd_error *err);

/* Squared distance from frame point p to tile t's box (0 inside). Inline:
 * the tiler asks it for every point near a border. */
static inline double wpd_tile_distance2(const wpd_tile *t, const double p[3])
{
    double d2 = 0;
    for (int a = 0; a < 3; a++) {
        double d = p[a] < t->box_lo[a] ? t->box_lo[a] - p[a]
                   : p[a] > t->box_hi[a] ? p[a] - t->box_hi[a] : 0;
        d2 += d * d;
    }
    return d2;
}

/* Distance from frame point p to tile t's box (0 inside). */
static inline double wpd_tile_distance(const wpd_tile *t, const double p[3])
{
    return sqrt(wpd_tile_distance2(t, p));
}

/* Distance between the boxes of tiles a and b (0 when they touch). */
static inline double wpd_tile_gap(const wpd_tile *a, const wpd_tile *b)
{
    double d2 = 0;
    for (int k = 0; k < 3; k++) {
        double d = a->box_lo[k] > b->box_hi[k] ? a->box_lo[k] - b->box_hi[k]
                   : b->box_lo[k] > a->box_hi[k] ? b->box_lo[k] - a->box_hi[k] : 0;
        d2 += d * d;
    }
    return sqrt(d2);
}

/* Whether p lies within band of the outside of tile t's box: near a face,
 * or outside it. A point of another tile within band of t's box passes
 * (tiles do not overlap), so such points are all a neighbour may ask for. */
static inline int wpd_tile_near_faces(const wpd_tile *t, const double p[3], double band)
{
    for (int a = 0; a < 3; a++)
        if (p[a] - t->box_lo[a] < band || t->box_hi[a] - p[a] < band)
            return 1;
    return 0;
}

void wpd_plan_free(wpd_plan *p);

#endif
