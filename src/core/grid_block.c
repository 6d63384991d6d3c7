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
                out->fx[out->n] = (float)(q[0] - out->corner[0]);
                out->fy[out->n] = (float)(q[1] - out->corner[1]);
                out->fz[out->n] = (float)(q[2] - out->corner[2]);
            }
        }
    return 1;
}

double wpd_block_margin(const wpd_grid *g, const int64_t c[3], const double *p)
{
    double margin = INFINITY;
    for (int k = 0; k < 3; k++) {
        int ax = g->axis[k];
        double lo = g->origin[ax] + (double)(c[k] - 1) * g->cell;
        double hi = g->origin[ax] + (double)(c[k] + 2) * g->cell;
        double in = p[ax] - lo < hi - p[ax] ? p[ax] - lo : hi - p[ax]; /* fmin: a call */
        margin = in < margin ? in : margin;
    }
    return margin;
}
