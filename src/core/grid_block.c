/* grid_block.c - the points around one cell of a grid (grid_block.h). */
#include "core/grid_block.h"

#include <math.h>
#include <string.h>

uint64_t wpd_grid_cell_of(const wpd_grid *g, const double *p, int64_t c[3])
{
    for (int k = 0; k < 3; k++) {
        int ax = g->axis[k];
        int64_t v = wpd_grid_coord(g, ax, p[ax]);
        c[k] = v < 0 ? 0 : v >= g->dim[ax] ? g->dim[ax] - 1 : v;
    }
    return (uint64_t)c[2] | (uint64_t)c[0] << g->shift_a | (uint64_t)c[1] << g->shift_b;
}

int wpd_block_gather(const wpd_grid *g, const int64_t c[3], int max, uint32_t own_slot,
                     wpd_block *out)
{
    out->n = 0;
    out->own = -1;
    for (int k = 0; k < 3; k++)
        out->corner[g->axis[k]] = g->origin[g->axis[k]] + (double)(c[k] - 1) * g->cell;
    for (int64_t b = c[1] - 1; b <= c[1] + 1; b++)
        for (int64_t a = c[0] - 1; a <= c[0] + 1; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, c[2] - 1, c[2] + 1, &sb, &se);
            if (out->n + (int)(se - sb) > max)
                return 0;
            if (own_slot >= sb && own_slot < se)
                out->own = out->n + (int)(own_slot - sb);
            for (uint32_t s = sb; s < se; s++, out->n++) {
                const double *q = g->xyz + 3 * (size_t)s;
                out->id[out->n] = g->id[s];
                memcpy(out->xyz + 3 * out->n, q, 3 * sizeof(double));
                float f[3];
                wpd_block_local(g, out, q, f);
                out->fx[out->n] = f[0], out->fy[out->n] = f[1], out->fz[out->n] = f[2];
            }
        }
    return 1;
}

int wpd_block_holds(const wpd_grid *g, const int64_t c[3], const double *p, double d2)
{
    /* Most points lie inside the block's edges as computed here by more
     * than those can differ from the rounding that keyed the points (a few
     * ulps of the coordinates, origin and edge: 2^-48 of their sum leaves
     * room). */
    double margin = INFINITY;
    for (int k = 0; k < 3; k++) {
        int ax = g->axis[k];
        double lo = g->origin[ax] + (double)(c[k] - 1) * g->cell;
        double hi = g->origin[ax] + (double)(c[k] + 2) * g->cell;
        double eps = (fabs(p[ax]) + fabs(g->origin[ax]) + fabs(hi) + fabs(lo)) * 0x1p-48;
        double in = (p[ax] - lo < hi - p[ax] ? p[ax] - lo : hi - p[ax]) - eps; /* fmin: a call */
        margin = in < margin ? in : margin;
    }
    if (margin > 0 && d2 * (1 + 0x1p-38) < margin * margin) /* room for the roundings */
        return 1;
    /* Wider than sqrt(d2) by more than the roundings of the square root
     * and of p - rho. */
    double rho = sqrt(d2) * (1 + 0x1p-40);
    /* Near an edge, the keys' own rounding: wpd_grid_coord never decreases
     * as its value grows, so a point whose cell lies outside [lo, hi] is
     * farther than rho along this axis. */
    for (int k = 0; k < 3; k++) {
        int ax = g->axis[k];
        double m = rho + fabs(p[ax]) * 0x1p-50;
        int64_t at = wpd_grid_coord(g, ax, p[ax]);
        int64_t lo = wpd_grid_coord(g, ax, p[ax] - m), hi = wpd_grid_coord(g, ax, p[ax] + m);
        lo = lo < 0 ? 0 : lo; /* the grid's points lie in its cells */
        hi = hi > g->dim[ax] - 1 ? g->dim[ax] - 1 : hi;
        if (at < c[k] - 1 || at > c[k] + 1 || lo < c[k] - 1 || hi > c[k] + 1)
            return 0;
    }
    return 1;
}
