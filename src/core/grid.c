/* grid.c - building the sorted-cell spatial grid. */
#include "core/grid.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/bits.h"
#include "core/sort.h"
#include "common/hugepage.h"

void wpd_point_bounds(const double *xyz, const uint32_t *subset, size_t n, double lo[3], double hi[3],
                int threads)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
    double x0 = INFINITY, y0 = INFINITY, z0 = INFINITY;
    double x1 = -INFINITY, y1 = -INFINITY, z1 = -INFINITY;
    /* min and max are exact, so the reduction order does not matter. */
#pragma omp parallel for num_threads(threads) schedule(static) if (n > 65536) \
    reduction(min : x0, y0, z0) reduction(max : x1, y1, z1)
    for (size_t i = 0; i < n; i++) {
        const double *p = xyz + 3 * (subset ? subset[i] : i);
        /* Plain comparisons (coordinates are finite): fmin/fmax are calls. */
        x0 = p[0] < x0 ? p[0] : x0;
        y0 = p[1] < y0 ? p[1] : y0;
        z0 = p[2] < z0 ? p[2] : z0;
        x1 = p[0] > x1 ? p[0] : x1;
        y1 = p[1] > y1 ? p[1] : y1;
        z1 = p[2] > z1 ? p[2] : z1;
    }
    if (n == 0)
        x0 = y0 = z0 = x1 = y1 = z1 = 0;
    lo[0] = x0; lo[1] = y0; lo[2] = z0;
    hi[0] = x1; hi[1] = y1; hi[2] = z1;
}

/* Cell size, dimensions, axis roles and key shifts; g->origin must be set.
 * Returns the number of key bits. */
static int plan_layout(wpd_grid *g, const double hi[3], double cell)
{
    for (;;) {
        g->cell = cell;
        g->inv_cell = 1.0 / cell;
        int b[3];
        for (int a = 0; a < 3; a++) {
            /* The same rounding as the keys, so the top point is inside. */
            g->dim[a] = wpd_grid_coord(g, a, hi[a]) + 1;
            b[a] = wpd_bits_for(g->dim[a]);
        }
        if (b[0] + b[1] + b[2] <= 63) {
            int c = 2; /* the axis with the fewest cells runs inside columns */
            if (g->dim[1] < g->dim[c])
                c = 1;
            if (g->dim[0] < g->dim[c])
                c = 0;
            g->axis[2] = c;
            g->axis[0] = c == 0 ? 1 : 0;
            g->axis[1] = c == 2 ? 1 : 2;
            g->shift_a = b[c];
            g->shift_b = b[c] + b[g->axis[0]];
            return b[0] + b[1] + b[2];
        }
        cell *= 2;
    }
}

/* Dense column index of a key. */
static uint64_t column_of(const wpd_grid *g, uint64_t key)
{
    uint64_t ia = (key >> g->shift_a) & (((uint64_t)1 << (g->shift_b - g->shift_a)) - 1);
    uint64_t ib = key >> g->shift_b;
    return ia + (uint64_t)g->dim[g->axis[0]] * ib;
}

static void free_columns(wpd_grid *g)
{
    free(g->col_run);
    free(g->tab_key);
    free(g->tab_run);
    free(g->tab_end);
    g->col_run = NULL;
    g->tab_key = NULL;
    g->tab_run = g->tab_end = NULL;
}

/* Largest number of columns indexed by a dense array (4 bytes each, so at
 * most about as much memory as the points' own slots). */
static double dense_limit(size_t n)
{
    return 6.0 * (double)n + 4096;
}

/* The axis along which the points' box is thinnest (runs inside columns). */
static int thinnest_axis(const double lo[3], const double hi[3])
{
    int c = 2;
    if (hi[1] - lo[1] < hi[c] - lo[c])
        c = 1;
    if (hi[0] - lo[0] < hi[c] - lo[c])
        c = 0;
    return c;
}

/* Column index: a dense array when it costs no more memory than the slots,
 * else an open-addressing table. */
static int build_columns(wpd_grid *g, const uint64_t *sorted_key)
{
    uint64_t cols = (uint64_t)g->dim[g->axis[0]] * (uint64_t)g->dim[g->axis[1]];
    free_columns(g);
    if ((double)cols <= dense_limit(g->n)) {
        g->col_run = calloc(cols + 1, sizeof *g->col_run);
        if (!g->col_run)
            return -1;
        for (size_t r = 0; r < g->nruns; r++)
            g->col_run[column_of(g, sorted_key[g->run_start[r]]) + 1]++;
        for (uint64_t c = 0; c < cols; c++)
            g->col_run[c + 1] += g->col_run[c];
        return 0;
    }
    size_t ncols = 0;
    for (size_t r = 0; r < g->nruns; r++)
        if (r == 0 || column_of(g, sorted_key[g->run_start[r]]) !=
                          column_of(g, sorted_key[g->run_start[r - 1]]))
            ncols++;
    size_t cap = 16;
    int bits = 4;
    while (cap < 2 * ncols) {
        cap <<= 1;
        bits++;
    }
    g->tab_mask = cap - 1;
    g->tab_shift = 64 - bits;
    g->tab_key = malloc(cap * sizeof *g->tab_key);
    g->tab_run = malloc(cap * sizeof *g->tab_run);
    g->tab_end = malloc(cap * sizeof *g->tab_end);
    if (!g->tab_key || !g->tab_run || !g->tab_end)
        return -1;
    memset(g->tab_key, 0xff, cap * sizeof *g->tab_key);
    for (size_t r = 0; r < g->nruns;) {
        uint64_t col = column_of(g, sorted_key[g->run_start[r]]);
        size_t end = r + 1;
        while (end < g->nruns && column_of(g, sorted_key[g->run_start[end]]) == col)
            end++;
        uint64_t h = (col * 0x9e3779b97f4a7c15ULL) >> g->tab_shift;
        for (;; h++) {
            h &= g->tab_mask;
            if (g->tab_key[h] == WPD_GRID_EMPTY)
                break;
        }
        g->tab_key[h] = col;
        g->tab_run[h] = (uint32_t)r;
        g->tab_end[h] = (uint32_t)end;
        r = end;
    }
    return 0;
}

static int grow(void *pp, size_t bytes)
{
    void **p = pp;
    void *q = wpd_realloc_large(*p, bytes);
    if (!q)
        return -1;
    *p = q;
    return 0;
}

int wpd_grid_build(wpd_grid *g, const double *xyz, const uint32_t *subset,
                   size_t n, double cell, int threads, wpd_error *err)
{
    if (n >= UINT32_MAX - 1)
        return wpd_fail(err, WPD_E_INPUT, "grid: %zu points in one block, at most %u allowed",
                        n, UINT32_MAX - 2);
    if (!(cell > 0) || !isfinite(cell))
        cell = 1.0;
    if (threads <= 0)
        threads = omp_get_max_threads();
    uint64_t *key = NULL, *tmp_key = NULL;
    uint32_t *tmp_id = NULL;
    if (g->cap < n || !g->id) {
        if (grow(&g->id, n * sizeof *g->id) < 0 || grow(&g->xyz, 3 * n * sizeof *g->xyz) < 0 ||
            grow(&g->run_start, (n + 1) * sizeof *g->run_start) < 0 ||
            grow(&g->run_c, (n + 1) * sizeof *g->run_c) < 0)
            goto oom;
        g->cap = n;
    }
    g->n = n;
    double hi[3];
    wpd_point_bounds(xyz, subset, n, g->origin, hi, threads);
    /* A dense column index is much faster than a hashed one (neighbouring
     * columns share cache lines): enlarge the cell up to twice for one. */
    for (int step = 0; step < 4; step++) {
        double c = cell * (step == 0 ? 1 : step == 1 ? 1.26 : step == 2 ? 1.59 : 2.0);
        double cols = 1;
        for (int a = 0; a < 3; a++)
            if (a != thinnest_axis(g->origin, hi))
                cols *= floor((hi[a] - g->origin[a]) / c) + 1;
        if (cols <= dense_limit(n)) {
            cell = c;
            break;
        }
    }
    int bits = plan_layout(g, hi, cell);

    key = wpd_malloc_large(n * sizeof *key);
    tmp_key = wpd_malloc_large(n * sizeof *tmp_key);
    tmp_id = wpd_malloc_large(n * sizeof *tmp_id);
    if (!key || !tmp_key || !tmp_id)
        goto oom;
    int ax = g->axis[0], bx = g->axis[1], cx = g->axis[2];
#pragma omp parallel for num_threads(threads) schedule(static)
    for (size_t i = 0; i < n; i++) {
        size_t src = subset ? subset[i] : i;
        const double *p = xyz + 3 * src;
        uint64_t ia = (uint64_t)wpd_grid_coord(g, ax, p[ax]);
        uint64_t ib = (uint64_t)wpd_grid_coord(g, bx, p[bx]);
        uint64_t ic = (uint64_t)wpd_grid_coord(g, cx, p[cx]);
        key[i] = ic | (ia << g->shift_a) | (ib << g->shift_b);
        g->id[i] = (uint32_t)src;
    }
    if (bits > 0)
        wpd_radix_sort_u64_threads(key, g->id, n, bits, tmp_key, tmp_id, threads);

#pragma omp parallel for num_threads(threads) schedule(static)
    for (size_t s = 0; s < n; s++)
        memcpy(g->xyz + 3 * s, xyz + 3 * (size_t)g->id[s], 3 * sizeof(double));

    size_t nruns = 0;
    uint64_t c_mask = ((uint64_t)1 << g->shift_a) - 1;
    for (size_t s = 0; s < n; s++)
        if (s == 0 || key[s] != key[s - 1]) {
            g->run_start[nruns] = (uint32_t)s;
            g->run_c[nruns++] = (uint32_t)(key[s] & c_mask);
        }
    g->nruns = nruns;
    g->run_start[nruns] = (uint32_t)n;
    if (build_columns(g, key) < 0)
        goto oom;
    free(key);
    free(tmp_key);
    free(tmp_id);
    return 0;
oom:
    free(key);
    free(tmp_key);
    free(tmp_id);
    wpd_grid_free(g);
    return wpd_fail(err, WPD_E_MEMORY, "grid: out of memory for %zu points", n);
}

void wpd_grid_free(wpd_grid *g)
{
    free(g->id);
    free(g->xyz);
    free(g->run_start);
    free(g->run_c);
    free_columns(g);
    memset(g, 0, sizeof *g);
}

int wpd_grid_box(const wpd_grid *g, const double p[3], double rad, int64_t lo[3], int64_t hi[3])
{
    for (int k = 0; k < 3; k++) {
        int a = g->axis[k];
        lo[k] = wpd_grid_coord(g, a, p[a] - rad);
        hi[k] = wpd_grid_coord(g, a, p[a] + rad);
        if (lo[k] < 0)
            lo[k] = 0;
        if (hi[k] >= g->dim[a])
            hi[k] = g->dim[a] - 1;
        if (lo[k] > hi[k] || g->n == 0)
            return 0;
    }
    return 1;
}

int wpd_grid_cell(const wpd_grid *g, int64_t ix, int64_t iy, int64_t iz, uint32_t *sb, uint32_t *se)
{
    int64_t i[3] = {ix, iy, iz};
    int64_t c = i[g->axis[2]];
    *sb = *se = 0;
    if (g->n == 0 || c < 0 || c >= g->dim[g->axis[2]])
        return 0;
    wpd_grid_column_slots(g, i[g->axis[0]], i[g->axis[1]], c, c, sb, se);
    return *se > *sb;
}
