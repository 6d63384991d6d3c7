/* grid.h - a spatial hash grid over a block of points.
 *
 * Points are sorted (radix sort, no per-cell allocation) by the key of their
 * cubic cell. The key orders cells column by column: the axis with the
 * fewest cells (z for airborne scans) runs inside a column, so the cells of
 * one column that a query needs are one contiguous range of slots. Columns
 * are found through a dense array (or, when the block is too sparse for
 * one, an open-addressing table). The grid keeps its own copy of the
 * coordinates in slot order, so scans read contiguous memory. Cell (0,0,0)
 * starts at the minimum corner of the points; queries may lie anywhere.
 *
 * A built grid is immutable: any number of threads may query it.
 */
#ifndef WPD_CORE_GRID_H
#define WPD_CORE_GRID_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"

typedef struct wpd_grid {
    size_t n;             /* points (slots) */
    double cell;          /* cell edge length */
    double inv_cell;
    double origin[3];     /* minimum corner of cell (0,0,0) */
    int64_t dim[3];       /* cells per axis */
    int axis[3];          /* axis[0], axis[1] index columns; axis[2] runs inside one */
    int shift_a, shift_b; /* key = c | a << shift_a | b << shift_b */
    uint32_t *id;         /* [n] index of the source point of each slot */
    double *xyz;          /* [3n] coordinates of each slot */
    size_t nruns;         /* occupied cells, in key order */
    uint32_t *run_start;  /* [nruns + 1] first slot of each occupied cell */
    uint32_t *run_c;      /* [nruns] cell index along axis[2] of each run */
    /* Columns: dense (col_run != NULL) or hashed. */
    uint32_t *col_run;    /* [dim[axis0] * dim[axis1] + 1] first run of each column */
    uint64_t *tab_key;    /* hashed columns: column key or WPD_GRID_EMPTY */
    uint32_t *tab_run;    /* first run of that column */
    uint32_t *tab_end;    /* end of its runs */
    uint64_t tab_mask;
    int tab_shift;        /* 64 - log2(table size): hash = top bits of col * golden */
    size_t cap;           /* points the slot arrays can hold (reuse) */
} wpd_grid;

#define WPD_GRID_EMPTY UINT64_MAX

/* Builds a grid with cells of edge `cell` (> 0) over the points
 * xyz[3*i..3*i+2] for i in subset[0..n-1], or for i in 0..n-1 when subset is
 * NULL; slot ids are those source indices. g must be zeroed or a grid built
 * before (its memory is reused). If the extent divided by cell needs more
 * than 63 bits of cell index, the cell is enlarged (queries stay exact, only
 * slower). threads <= 0 means the OpenMP default. Returns 0, or -1 with err
 * set (WPD_E_MEMORY; WPD_E_INPUT when n exceeds 2^32 - 2). */
int wpd_grid_build(wpd_grid *g, const double *xyz, const uint32_t *subset,
                   size_t n, double cell, int threads, wpd_error *err);

/* Bounding box of n points (x y z each), or of xyz[3*subset[i]..] when
 * subset is not NULL; all zero when n == 0. Exact whatever the threads. */
void wpd_point_bounds(const double *xyz, const uint32_t *subset, size_t n, double lo[3], double hi[3],
                int threads);

/* Frees everything a grid owns and zeroes it. Zeroed grids are fine. */
void wpd_grid_free(wpd_grid *g);

/* Cell index of coordinate v on axis a (may be outside 0..dim[a]-1). */
static inline int64_t wpd_grid_coord(const wpd_grid *g, int a, double v)
{
    double c = (v - g->origin[a]) * g->inv_cell;
    if (c < -1e15)
        c = -1e15;
    if (c > 1e15)
        c = 1e15;
    int64_t i = (int64_t)c;
    return i - (c < (double)i); /* floor */
}

/* Runs [*rb, *re) of column (ia, ib) (cell indices along axis[0], axis[1]). */
static inline void wpd_grid_column(const wpd_grid *g, int64_t ia, int64_t ib,
                                   uint32_t *rb, uint32_t *re)
{
    int64_t da = g->dim[g->axis[0]], db = g->dim[g->axis[1]];
    *rb = *re = 0;
    if (ia < 0 || ib < 0 || ia >= da || ib >= db)
        return;
    uint64_t col = (uint64_t)ia + (uint64_t)da * (uint64_t)ib;
    if (g->col_run) {
        *rb = g->col_run[col];
        *re = g->col_run[col + 1];
        return;
    }
    uint64_t h = (col * 0x9e3779b97f4a7c15ULL) >> g->tab_shift;
    for (;;) {
        h &= g->tab_mask;
        uint64_t k = g->tab_key[h];
        if (k == col) {
            *rb = g->tab_run[h];
            *re = g->tab_end[h];
            return;
        }
        if (k == WPD_GRID_EMPTY)
            return;
        h++;
    }
}

/* Slot range [*sb, *se) of the cells of column (ia, ib) whose index along
 * axis[2] lies in [clo, chi]; those cells are consecutive slots. */
static inline void wpd_grid_column_slots(const wpd_grid *g, int64_t ia, int64_t ib,
                                         int64_t clo, int64_t chi, uint32_t *sb, uint32_t *se)
{
    uint32_t rb, re;
    wpd_grid_column(g, ia, ib, &rb, &re);
    while (rb < re && (int64_t)g->run_c[rb] < clo)
        rb++;
    uint32_t last = rb;
    while (last < re && (int64_t)g->run_c[last] <= chi)
        last++;
    *sb = g->run_start[rb];
    *se = g->run_start[last];
}

/* The cells overlapping the box [p - rad, p + rad], in column coordinates:
 * columns a in [lo[0], hi[0]], b in [lo[1], hi[1]], cells c in [lo[2], hi[2]].
 * Returns 0 when the box misses the grid. */
int wpd_grid_box(const wpd_grid *g, const double p[3], double rad, int64_t lo[3], int64_t hi[3]);

/* Slot range of cell (ix, iy, iz) (indices along x, y, z); 0 if empty. */
int wpd_grid_cell(const wpd_grid *g, int64_t ix, int64_t iy, int64_t iz, uint32_t *sb, uint32_t *se);

#endif
