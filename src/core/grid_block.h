/* grid_block.h - the points of the 3 x 3 x 3 cells around one cell of a
 * grid, gathered once for the queries of that cell's points, also as
 * floats relative to the block's corner: distances to all of them are then
 * computed in float, several at a time, and only the few that the floats
 * cannot order are compared in double. The exact count's two nearest
 * samples (method/eliminate.c) and every sample's k nearest
 * (core/knn_batch.c) work this way.
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
    float fx[WPD_BLOCK_MAX], fy[WPD_BLOCK_MAX], fz[WPD_BLOCK_MAX];
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

/* How far p lies inside the 3 x 3 x 3 cells around c (negative outside):
 * no point outside the block is nearer to p than that. */
double wpd_block_margin(const wpd_grid *g, const int64_t c[3], const double *p);

#endif
