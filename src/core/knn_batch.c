/* knn_batch.c - every point's k nearest others at once, cell by cell
 * (knn_batch.h). */
#include "core/knn_batch.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/knn.h"

/* Points gathered around a cell at most; a more crowded block's points are
 * searched for alone. */
#define GATHER_MAX 1024

/* Points below the threshold that are sorted at most: more, and the
 * threshold is lowered. */
#define BELOW_MAX 64

/* The points of the 3 x 3 x 3 cells around a cell, also as floats relative
 * to the block's corner (within 3 cells of it, as are the queries). */
typedef struct gathered {
    int n;
    int own;             /* position of the centre cell's first point */
    double corner[3];
    uint32_t id[GATHER_MAX];
    double xyz[3 * GATHER_MAX];
    float fx[GATHER_MAX], fy[GATHER_MAX], fz[GATHER_MAX];
    float fd[GATHER_MAX]; /* one point's float squared distances to them */
} gathered;

/* Cell indices (column coordinates) of the cell holding slot s. */
static void cell_of_slot(const wpd_grid *g, uint32_t s, int64_t c[3])
{
    for (int k = 0; k < 3; k++) {
        int ax = g->axis[k];
        int64_t v = wpd_grid_coord(g, ax, g->xyz[3 * (size_t)s + ax]);
        c[k] = v < 0 ? 0 : v >= g->dim[ax] ? g->dim[ax] - 1 : v;
    }
}

/* The points of the cells around c (whose first slot is first) into *out;
 * 0 when they do not fit. */
static int gather(const wpd_grid *g, const int64_t c[3], uint32_t first, gathered *out)
{
    out->n = 0;
    out->own = -1;
    for (int k = 0; k < 3; k++)
        out->corner[g->axis[k]] = g->origin[g->axis[k]] + (double)(c[k] - 1) * g->cell;
    for (int64_t b = c[1] - 1; b <= c[1] + 1; b++)
        for (int64_t a = c[0] - 1; a <= c[0] + 1; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, c[2] - 1, c[2] + 1, &sb, &se);
            if (out->n + (int)(se - sb) > GATHER_MAX)
                return 0;
            if (first >= sb && first < se)
                out->own = out->n + (int)(first - sb);
            for (uint32_t s = sb; s < se; s++, out->n++) {
                const double *q = g->xyz + 3 * (size_t)s;
                out->id[out->n] = g->id[s];
                memcpy(out->xyz + 3 * out->n, q, 3 * sizeof(double));
                out->fx[out->n] = (float)(q[0] - out->corner[0]);
                out->fy[out->n] = (float)(q[1] - out->corner[1]);
                out->fz[out->n] = (float)(q[2] - out->corner[2]);
            }
        }
    return out->own >= 0;
}

/* How far p lies inside the 3 x 3 x 3 cells around c (negative outside). */
static double inner_margin(const wpd_grid *g, const int64_t c[3], const double *p)
{
    double margin = INFINITY;
    for (int k = 0; k < 3; k++) {
        int ax = g->axis[k];
        double lo = g->origin[ax] + (double)(c[k] - 1) * g->cell;
        double hi = g->origin[ax] + (double)(c[k] + 2) * g->cell;
        double in = p[ax] - lo < hi - p[ax] ? p[ax] - lo : hi - p[ax];
        margin = in < margin ? in : margin;
    }
    return margin;
}

/* How far two float squared distances within a 3 x 3 x 3 block may differ
 * from their order in double, with room to spare. Coordinates relative to
 * the corner lie within 3 cells, so each float coordinate and difference
 * errs by at most 2^-24 * 3 cells; a squared distance (at most 27 cells^2)
 * then by at most about 1.5e-5 cells^2, and a pair of them by twice that:
 * 9e-5 cells^2 leaves a factor 3. */
static float float_slack(const wpd_grid *g)
{
    return (float)(9e-5 * g->cell * g->cell);
}

/* How many of near->fd[0..n) are at most t. */
static int count_below(const gathered *near, float t)
{
    int c = 0;
#pragma omp simd reduction(+ : c)
    for (int j = 0; j < near->n; j++)
        c += near->fd[j] <= t;
    return c;
}

/* Gathered point j's exact squared distance from p, as wpd_knn computes
 * it. */
static double exact_d2(const gathered *near, int j, const double *p)
{
    const double *q = near->xyz + 3 * j;
    double dx = q[0] - p[0], dy = q[1] - p[1], dz = q[2] - p[2];
    return dx * dx + dy * dy + dz * dz;
}

/* The k nearest others of the gathered point own, exactly ordered, into
 * idx/d2; *t is the threshold to start from, and leaves as this point's
 * k-th float distance (the next point's start). Returns 0 when the floats
 * cannot settle them (the point is then searched for alone). */
static int settle(const wpd_grid *g, gathered *near, const int64_t c[3], int own, int k,
                  float *t, uint32_t *idx, double *d2)
{
    int n = near->n;
    if (n < k + 2)
        return 0;
    float px = near->fx[own], py = near->fy[own], pz = near->fz[own];
#pragma omp simd
    for (int j = 0; j < n; j++) {
        float dx = near->fx[j] - px, dy = near->fy[j] - py, dz = near->fz[j] - pz;
        near->fd[j] = dx * dx + dy * dy + dz * dz;
    }
    near->fd[own] = INFINITY;
    /* A threshold below which k + 1 to 2k + 8 points lie: counting is
     * cheap, sorting is not. */
    int below = count_below(near, *t), most = 2 * k + 8 < BELOW_MAX ? 2 * k + 8 : BELOW_MAX;
    for (int tries = 0; below < k + 1 || below > most; tries++) {
        if (tries == 16)
            return 0;
        *t *= below < k + 1 ? 1.3f : 0.8f;
        below = count_below(near, *t);
    }
    /* Those points, picked without a branch a point (which of them lie
     * below is data, not a pattern a predictor learns), then sorted by
     * float distance. */
    float bd[BELOW_MAX + 1];
    int bj[BELOW_MAX + 1], m = 0;
    for (int j = 0; j < n; j++) {
        bj[m] = j;
        m += near->fd[j] <= *t;
        m = m < BELOW_MAX ? m : BELOW_MAX; /* the count said at most that many */
    }
    for (int a = 0; a < m; a++) {
        int j = bj[a], at = a;
        float v = near->fd[j];
        for (; at > 0 && bd[at - 1] > v; at--) {
            bd[at] = bd[at - 1];
            bj[at] = bj[at - 1];
        }
        bd[at] = v;
        bj[at] = j;
    }
    *t = bd[k] * 1.05f; /* neighbouring points have alike distances */
    /* Every point left out is at least bd[k] away in floats, every chosen
     * one at most bd[k - 1]: past the floats' error, the chosen are
     * strictly nearer in double. */
    if (!(bd[k] - bd[k - 1] > float_slack(g)))
        return 0;
    const double *p = near->xyz + 3 * own;
    for (int j = 0; j < k; j++) {
        double d = exact_d2(near, bj[j], p);
        uint32_t id = near->id[bj[j]];
        int at = j;
        for (; at > 0 && (d2[at - 1] > d || (d2[at - 1] == d && idx[at - 1] > id)); at--) {
            d2[at] = d2[at - 1];
            idx[at] = idx[at - 1];
        }
        d2[at] = d;
        idx[at] = id;
    }
    /* A point beyond the block lies at least the margin away: it cannot
     * be nearer than the k-th, nor as near. */
    double mg = inner_margin(g, c, p);
    return mg > 0 && d2[k - 1] < mg * mg;
}

/* Answers the points of one cell (slots first..end-1) whose index is below
 * nq. */
static size_t answer_cell(const wpd_grid *g, size_t nq, int k, const uint32_t *rows,
                          uint32_t *idx, double *d2, uint8_t *count, uint32_t first,
                          uint32_t end, gathered *near)
{
    size_t alone = 0;
    int64_t c[3];
    cell_of_slot(g, first, c);
    int have = k < BELOW_MAX && gather(g, c, first, near);
    /* The first threshold: the cell's squared size (its k-th neighbour lies
     * about 1 / 1.5 cell away), then the previous point's. */
    float t = (float)(g->cell * g->cell);
    for (uint32_t s = first; s < end; s++) {
        uint32_t i = g->id[s];
        if (i >= nq)
            continue;
        size_t row = rows ? rows[i] : i;
        uint32_t *ri = idx + row * (size_t)k;
        double scratch[WPD_KNN_MAX], *rd = d2 ? d2 + row * (size_t)k : scratch;
        if (have && settle(g, near, c, near->own + (int)(s - first), k, &t, ri, rd)) {
            count[row] = (uint8_t)k;
            continue;
        }
        count[row] = (uint8_t)wpd_knn(g, g->xyz + 3 * (size_t)s, k, i, INFINITY, g->cell, ri, rd);
        alone++;
    }
    return alone;
}

int wpd_knn_batch(const wpd_grid *g, size_t nq, int k, const uint32_t *rows, uint32_t *idx,
                  double *d2, uint8_t *count, int threads, size_t *alone, wpd_error *err)
{
    int failed = 0;
    size_t searched = 0;
    if (threads <= 0)
        threads = omp_get_max_threads();
#pragma omp parallel num_threads(threads) reduction(| : failed) reduction(+ : searched)
    {
        gathered *near = malloc(sizeof *near);
        failed = !near;
#pragma omp for schedule(dynamic, 64)
        for (size_t r = 0; r < g->nruns; r++)
            if (near)
                searched += answer_cell(g, nq, k, rows, idx, d2, count, g->run_start[r],
                                        g->run_start[r + 1], near);
        free(near);
    }
    if (alone)
        *alone = searched;
    if (failed)
        return wpd_fail(err, WPD_E_MEMORY, "knn: out of memory for the batch of %d threads",
                        threads);
    return 0;
}
