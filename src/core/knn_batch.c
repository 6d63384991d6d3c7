/* knn_batch.c - every point's k nearest others at once, cell by cell
 * (knn_batch.h). */
#include "core/knn_batch.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid_block.h"
#include "core/knn.h"

/* Points below the threshold that are sorted at most: more, and the
 * threshold is lowered. */
#define BELOW_MAX 64

typedef wpd_block gathered;

/* How far two float squared distances within the block (in cell units,
 * core/grid_block.h) may differ from their order in double, with room to
 * spare. A coordinate in [0, 3] errs by at most 2^-24 * 3, a difference of
 * two (at most 2 apart: the query lies in the centre cell) by three times
 * that, a squared distance (at most 12) with its own roundings by about
 * 1.5e-5, and a pair of them by twice that: 9e-5 leaves a factor 3. */
#define FLOAT_SLACK 9e-5f

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
 * idx/d2; *t is the threshold to start from, and leaves a little above
 * this point's (k+1)-th float distance (the next point's start). Returns 0
 * when the floats cannot settle them (the point is then searched for
 * alone). */
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
    if (!(bd[k] - bd[k - 1] > FLOAT_SLACK))
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
    /* wpd_knn skips every point with the query's index (a grid over a
     * subset may hold one twice); here only the query's own slot is out. */
    for (int j = 0; j < k; j++)
        if (idx[j] == near->id[own])
            return 0;
    /* No point beyond the block as near as the k-th. */
    return wpd_block_holds(g, c, p, d2[k - 1]);
}

/* How many of the n nearest (d2 ascending) lie within max_dist, as
 * wpd_knn's limit counts them (d2 <= max_dist^2). */
static int within(const double *d2, int n, double max_dist)
{
    double lim = isinf(max_dist) ? INFINITY : max_dist * max_dist;
    while (n > 0 && !(d2[n - 1] <= lim))
        n--;
    return n;
}

/* Answers the points of one cell (slots first..end-1) whose index is below
 * nq. */
static size_t answer_cell(const wpd_grid *g, size_t nq, int k, double max_dist,
                          const uint32_t *rows, uint32_t *idx, double *d2, uint8_t *count,
                          uint32_t first, uint32_t end, gathered *near)
{
    size_t alone = 0;
    int64_t c[3];
    wpd_grid_cell_of(g, g->xyz + 3 * (size_t)first, c);
    int have = k < BELOW_MAX && wpd_block_gather(g, c, WPD_BLOCK_MAX, first, near) &&
               near->own >= 0;
    /* The first threshold: a cell, squared (the k-th neighbour lies about
     * half a cell away), then the previous point's. */
    float t = 1;
    for (uint32_t s = first; s < end; s++) {
        uint32_t i = g->id[s];
        if (i >= nq)
            continue;
        size_t row = rows ? rows[i] : i;
        uint32_t *ri = idx + row * (size_t)k;
        double scratch[WPD_KNN_MAX], *rd = d2 ? d2 + row * (size_t)k : scratch;
        if (have && settle(g, near, c, near->own + (int)(s - first), k, &t, ri, rd)) {
            count[row] = (uint8_t)within(rd, k, max_dist);
            continue;
        }
        count[row] = (uint8_t)wpd_knn(g, g->xyz + 3 * (size_t)s, k, i, max_dist,
                                      g->cell < max_dist ? g->cell : max_dist, ri, rd);
        alone++;
    }
    return alone;
}

int wpd_knn_batch(const wpd_grid *g, size_t nq, int k, double max_dist, const uint32_t *rows,
                  uint32_t *idx, double *d2, uint8_t *count, int threads, size_t *alone,
                  wpd_error *err)
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
                searched += answer_cell(g, nq, k, max_dist, rows, idx, d2, count,
                                        g->run_start[r], g->run_start[r + 1], near);
        free(near);
    }
    if (alone)
        *alone = searched;
    if (failed)
        return wpd_fail(err, WPD_E_MEMORY, "knn: out of memory for the batch of %d threads",
                        threads);
    return 0;
}
