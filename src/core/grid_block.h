/* grid_block.h - the points of the 3 x 3 x 3 cells around one cell of a
 * grid, gathered once for the queries of that cell's points, also as
 * floats in cell units from the block's corner: distances to all of them
 * are then computed in float, several at a time, and only the few that the
 * floats cannot order are compared in double. The exact count's two
 * nearest samples (method/eliminate.c) and every sample's k nearest
 * (core/knn_batch.c) work this way.
 *
 * Why cell units: a float coordinate in [0, 3] errs by at most 2^-24 of 3
 * whatever the cloud's scale, so a squared distance between two points of
 * the block (at most 27) errs by a few 1e-6, and a fixed slack bounds it.
 * In the cloud's units the squares of tiny cells underflow into denormals
 * and those of huge cells overflow, where no relative bound holds.
 */
#ifndef WPD_CORE_GRID_BLOCK_H
#define WPD_CORE_GRID_BLOCK_H

#include <stdint.h>

#include "core/grid.h"

/* Most points a block holds. */
#define WPD_BLOCK_MAX 1024
/* fd's room past n, to pad a loop to whole groups of this many lanes. */
#define WPD_BLOCK_PAD 8

typedef struct wpd_block {
    int n;
    int own;               /* position of the slot asked for, or -1 */
    double corner[3];      /* minimum corner of the block */
    uint32_t id[WPD_BLOCK_MAX];
    double xyz[3 * WPD_BLOCK_MAX];
    float fx[WPD_BLOCK_MAX], fy[WPD_BLOCK_MAX], fz[WPD_BLOCK_MAX]; /* cell units */
    float fd[WPD_BLOCK_MAX + WPD_BLOCK_PAD]; /* one query's float distances */
} wpd_block;

/* The cell holding p, clamped into the grid: its coordinates in column
 * order (axis[0], axis[1], axis[2]) into c, and its key in the grid's slot
 * order as the result. */
uint64_t wpd_grid_cell_of(const wpd_grid *g, const double *p, int64_t c[3]);

/* The points of the cells around cell c into *out (at most max <=
 * WPD_BLOCK_MAX), and in out->own the position of slot `own_slot` among
 * them (-1 if it is not there). Returns 0 when they do not fit. */
int wpd_block_gather(const wpd_grid *g, const int64_t c[3], int max, uint32_t own_slot,
                     wpd_block *out);

/* p as the block's floats: in cell units from its corner. */
static inline void wpd_block_local(const wpd_grid *g, const wpd_block *b, const double *p,
                                   float f[3])
{
    for (int a = 0; a < 3; a++)
        f[a] = (float)((p[a] - b->corner[a]) * g->inv_cell);
}

/* 1 if p lies in the 3 x 3 x 3 cells around c and every point of the grid
 * within sqrt(d2) of p (that far included) lies in them too, judged with
 * the rounding that put the points in their cells (a margin computed from
 * the cells' edges can differ from it by an ulp). Then no point outside
 * the block is as near to p as d2. */
int wpd_block_holds(const wpd_grid *g, const int64_t c[3], const double *p, double d2);

#endif
