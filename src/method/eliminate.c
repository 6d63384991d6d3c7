/* eliminate.c - coverage-aware elimination (eliminate.h). */
#include "method/eliminate.h"

#include <float.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "core/bits.h"
#include "core/grid_block.h"
#include "core/knn.h"
#include "core/knn_batch.h"
#include "core/sort.h"

/* Average samples an occupied cell of the elimination's grid holds at least
 * (unless the cells would pass the reach). */
#define ELIM_CELL_FILL 1.25

/* *p = max(*p, v) for any number of threads. */
static void atomic_max(uint64_t *p, uint64_t v)
{
    uint64_t cur = __atomic_load_n(p, __ATOMIC_RELAXED);
    while (v > cur &&
           !__atomic_compare_exchange_n(p, &cur, v, 1, __ATOMIC_RELAXED, __ATOMIC_RELAXED))
        ;
}

int wpd_eliminate_init(wpd_eliminate *e, const double *xyz, const uint8_t *half, size_t n,
                       double spacing, double reach, int threads, wpd_error *err)
{
    memset(e, 0, sizeof *e);
    e->n = e->live = n;
    e->xyz = xyz;
    e->half = half;
    e->spacing = spacing > 0 ? spacing : 1.0;
    e->reach = reach > 0 ? reach : INFINITY;
    e->threads = threads > 0 ? threads : omp_get_max_threads();
    size_t m = n ? n : 1;
    e->alive = malloc(m);
    e->cost = malloc(m * sizeof *e->cost);
    e->live_idx = malloc(m * sizeof *e->live_idx);
    if (!e->alive || !e->cost || !e->live_idx) {
        wpd_eliminate_free(e);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count of %zu samples", n);
    }
    memset(e->alive, 1, n);
    return 0;
}

void wpd_eliminate_free(wpd_eliminate *e)
{
    free(e->alive);
    free(e->cost);
    free(e->live_idx);
    wpd_grid_free(&e->grid);
    memset(e, 0, sizeof *e);
}

int wpd_eliminate_begin(wpd_eliminate *e, wpd_error *err)
{
    size_t m = 0;
    for (size_t i = 0; i < e->n; i++)
        if (e->alive[i])
            e->live_idx[m++] = (uint32_t)i;
    e->live = m;
    memset(e->cost, 0, e->n * sizeof *e->cost);
    /* Cells of 1.5 r: the second-nearest sample of an input point (about r
     * away) then lies within the 3 x 3 x 3 cells around it. Where the
     * samples stand much farther apart than r (an input sparser than the
     * radius: n near its size), cells of 1.5 r hold one sample each and a
     * search crosses thousands of empty cells to its nearest: the cells
     * grow until they hold about ELIM_CELL_FILL samples on average (the
     * searches are exact whatever the cell, so only their cost changes). */
    double cell = 1.5 * e->spacing;
    for (;;) {
        if (wpd_grid_build(&e->grid, e->xyz, e->live_idx, m, cell, e->threads, err))
            return -1;
        if ((double)e->grid.nruns * ELIM_CELL_FILL <= (double)m || e->grid.nruns <= 1 ||
            2 * cell > e->reach)
            return 0;
        cell *= 2;
    }
}

/* Points are queried in blocks of this many, each sorted by the samples'
 * grid cell on the thread that queries it: the sort and the queries stay
 * in cache, and no thread waits for one sort of every point. */
#define QUERY_BLOCK 65536

/* A thread's room to order one block. */
typedef struct block_order {
    uint64_t key[2 * QUERY_BLOCK];
    uint32_t val[2 * QUERY_BLOCK];
    double xyz[3 * QUERY_BLOCK]; /* the points in that order */
} block_order;

/* The points of pts[first..first+n-1] to query (skip[i] == 0), sorted by
 * the samples' grid cell: point indices in o->val, cell keys in o->key,
 * coordinates in o->xyz. Returns their count. */
static size_t order_block(const wpd_grid *g, const double *pts, const uint8_t *skip,
                          size_t first, size_t n, block_order *o)
{
    uint64_t top = 0;
    size_t m = 0;
    for (size_t i = first; i < first + n; i++)
        if (!skip || !skip[i]) {
            int64_t c[3];
            o->key[m] = wpd_grid_cell_of(g, pts + 3 * i, c);
            o->val[m] = (uint32_t)i;
            top |= o->key[m++];
        }
    int bits = 1;
    while (bits < 64 && top >> bits)
        bits++;
    wpd_radix_sort_u64(o->key, o->val, m, bits, o->key + QUERY_BLOCK, o->val + QUERY_BLOCK);
    /* Copied in one loop of independent loads, the scattered reads overlap;
     * inside the queries each would stall them. */
    for (size_t k = 0; k < m; k++)
        memcpy(o->xyz + 3 * k, pts + 3 * (size_t)o->val[k], 3 * sizeof *o->xyz);
    return m;
}

/* Up to GATHER_MAX samples of the 3 x 3 x 3 cells around a cell. */
#define GATHER_MAX 512

/* The two smallest of d[0..n-1] (duplicates counted: f1 == f0 when the
 * smallest occurs twice), INFINITY where there are fewer; d must have room
 * for n rounded up to TWO_LANES, which is overwritten with INFINITY. Each
 * of TWO_LANES lanes keeps its own two smallest and the lanes are merged
 * pairwise, all with min and max: the distances come in random order, and
 * a compare-and-branch version mispredicted on about every other sample
 * (a third of the cost queries' time). */
#define TWO_LANES 8
static void two_smallest(float *d, int n, float *f0, float *f1)
{
    float a[TWO_LANES], b[TWO_LANES];
    for (int k = n; k % TWO_LANES; k++)
        d[k] = INFINITY;
    for (int k = 0; k < TWO_LANES; k++)
        a[k] = b[k] = INFINITY;
    for (int j = 0; j < n; j += TWO_LANES) {
#pragma omp simd
        for (int k = 0; k < TWO_LANES; k++) {
            float v = d[j + k];
            float hi = v > a[k] ? v : a[k];
            b[k] = hi < b[k] ? hi : b[k];
            a[k] = v < a[k] ? v : a[k];
        }
    }
    for (int half = TWO_LANES / 2; half >= 1; half /= 2) {
#pragma omp simd
        for (int k = 0; k < half; k++) {
            float lo = a[k] < a[k + half] ? a[k] : a[k + half];
            float hi = a[k] < a[k + half] ? a[k + half] : a[k];
            float next = b[k] < b[k + half] ? b[k] : b[k + half];
            a[k] = lo;
            b[k] = hi < next ? hi : next;
        }
    }
    *f0 = a[0];
    *f1 = b[0];
}

/* The samples around a cell (core/grid_block.h): the distances to every
 * sample are computed in float, 4 or 8 at a time, and only the few within
 * the float error of the second-nearest are compared exactly. */
typedef wpd_block gathered;
_Static_assert(GATHER_MAX <= WPD_BLOCK_MAX && TWO_LANES <= WPD_BLOCK_PAD,
               "the tags and the lanes fit a block");

/* Offers sample j of near at exact squared distance from p to the two best
 * by (squared distance, index). */
static void offer(const gathered *near, int j, const double *p, double b[2], uint32_t i[2])
{
    const double *q = near->xyz + 3 * j;
    double dx = q[0] - p[0], dy = q[1] - p[1], dz = q[2] - p[2];
    double d = dx * dx + dy * dy + dz * dz;
    uint32_t id = near->id[j];
    if (d < b[0] || (d == b[0] && id < i[0])) {
        b[1] = b[0], i[1] = i[0], b[0] = d, i[0] = id;
    } else if (d < b[1] || (d == b[1] && id < i[1])) {
        b[1] = d, i[1] = id;
    }
}

/* How far the float squared distances of a 3 x 3 x 3 block (in cell
 * units, core/grid_block.h) may err, with room to spare: a few 1e-6 of
 * the block's squared size (9), bounded here by 1e-4 of it. Both ways of
 * finding two nearest samples in the floats rely on it. */
#define FLOAT_SLACK 9e-4f

/* The two nearest of the gathered samples to p (inside the block, so that
 * its float coordinates lie within the block's 3 cells), exactly as a
 * search in double would give them: the float distances find the second
 * nearest to within their error (FLOAT_SLACK), and every sample within
 * that slack of it is compared in double. Returns the number found (at
 * most 2). */
static int two_of_gathered(gathered *near, const wpd_grid *g, const double *p, double b[2],
                           uint32_t i[2])
{
    float f[3];
    wpd_block_local(g, near, p, f);
    float px = f[0], py = f[1], pz = f[2];
    int n = near->n;
    float *fd = near->fd;
#pragma omp simd
    for (int j = 0; j < n; j++) {
        float dx = near->fx[j] - px, dy = near->fy[j] - py, dz = near->fz[j] - pz;
        fd[j] = dx * dx + dy * dy + dz * dz;
    }
    float f0, f1;
    two_smallest(fd, n, &f0, &f1);
    b[0] = b[1] = INFINITY;
    i[0] = i[1] = UINT32_MAX;
    if (n < 2)
        return n;
    float slack = f1 + FLOAT_SLACK;
    for (int j = 0; j < n; j++)
        if (fd[j] <= slack)
            offer(near, j, p, b, i);
    return 2;
}

/* The nearest and second-nearest sample of p by (squared distance, index),
 * as wpd_knn gives them: from the gathered cells when the second lies
 * within their margin around p (then no other sample can be nearer), else
 * from a full search. Returns how many exist (at most 2). */
static int two_nearest(const wpd_grid *g, gathered *near, int have, const int64_t c[3],
                       const double *p, double hint, uint32_t idx[2], double d2[2])
{
    if (have) {
        double b[2];
        uint32_t i[2];
        if (two_of_gathered(near, g, p, b, i) == 2 && wpd_block_holds(g, c, p, b[1])) {
            idx[0] = i[0], idx[1] = i[1], d2[0] = b[0], d2[1] = b[1];
            return 2;
        }
    }
    return wpd_knn(g, p, 2, WPD_NO_SELF, INFINITY, hint, idx, d2);
}

/* Point p's part of the cost of its nearest sample, from its two nearest
 * idx/d2 (got of them, as two_nearest gives them), both within the reach
 * (eliminate.h). *nearest (when not NULL): that sample if strictly nearer
 * than every other, else WPD_ELIMINATE_NO_NEAREST. */
static void add_found(wpd_eliminate *e, int got, const uint32_t idx[2], const double d2[2],
                      uint32_t *nearest)
{
    double reach2 = e->reach * e->reach;
    if (got >= 1 && d2[0] <= reach2)
        atomic_max(&e->cost[idx[0]], wpd_double_bits(got == 2 && d2[1] < reach2 ? d2[1] : reach2));
    if (nearest)
        *nearest = got == 1 || (got == 2 && d2[0] < d2[1]) ? idx[0] : WPD_ELIMINATE_NO_NEAREST;
}

/* The same for a point whose two nearest are still to be found (near: the
 * samples around p's cell c, when have). */
static void add_one(wpd_eliminate *e, gathered *near, int have, const int64_t c[3],
                    const double *p, uint32_t *nearest)
{
    uint32_t idx[2];
    double d2[2];
    int got = two_nearest(&e->grid, near, have, c, p, e->grid.cell, idx, d2);
    add_found(e, got, idx, d2, nearest);
}

/* The points of a cell are answered eight at a time, one vector lane a
 * point: the float distance to every gathered sample, its low 9 mantissa
 * bits replaced by the sample's position among them (GATHER_MAX = 2^9), and
 * a network of min and max that keeps each point's three smallest. The
 * tags ride along at a cost of a relative 2^-14 in the values. A point
 * whose third is clear of its second by more than the floats' slack and
 * that cost has the two tagged samples as its two nearest, settled by two
 * exact distances; the others (near ties) take the way of one point alone.
 * (The distances and the network are two loops: one loop with both is not
 * vectorized by gcc.) */
#define POINT_LANES 8
#define TAG_BITS 9
#define TAG_MASK ((1u << TAG_BITS) - 1)

/* The three smallest tagged distances of each of the POINT_LANES points
 * (px, py, pz: near's floats, core/grid_block.h) into a0 <= a1 <= a2. */
static void three_smallest(const gathered *near, const float *px, const float *py,
                           const float *pz, float *a0, float *a1, float *a2)
{
    float d[POINT_LANES];
    for (int k = 0; k < POINT_LANES; k++)
        a0[k] = a1[k] = a2[k] = FLT_MAX; /* above every tagged value, as no sample */
    for (int j = 0; j < near->n; j++) {
        float qx = near->fx[j], qy = near->fy[j], qz = near->fz[j];
        uint32_t tag = (uint32_t)j;
#pragma omp simd
        for (int k = 0; k < POINT_LANES; k++) {
            float dx = qx - px[k], dy = qy - py[k], dz = qz - pz[k];
            float v = dx * dx + dy * dy + dz * dz;
            /* A tag in the mantissa of an infinite value would make it a
             * NaN (a point far outside the block), and one in zero a denormal,
             * which a flush-to-zero mode compares equal to another: both
             * are kept normal. Either clamp errs in the direction the gap
             * test tolerates (a clamped third never passes for a second). */
            v = v > FLT_MIN ? v : FLT_MIN;
            v = v < FLT_MAX ? v : FLT_MAX;
            uint32_t bits;
            memcpy(&bits, &v, sizeof bits);
            bits = (bits & ~TAG_MASK) | tag;
            memcpy(&d[k], &bits, sizeof bits);
        }
#pragma omp simd
        for (int k = 0; k < POINT_LANES; k++) {
            float v = d[k];
            float hi0 = v > a0[k] ? v : a0[k];
            a0[k] = v < a0[k] ? v : a0[k];
            float hi1 = hi0 > a1[k] ? hi0 : a1[k];
            a1[k] = hi0 < a1[k] ? hi0 : a1[k];
            a2[k] = hi1 < a2[k] ? hi1 : a2[k];
        }
    }
}

static uint32_t tag_of(float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    return bits & TAG_MASK;
}

/* Answers o's points first..end-1, all in grid cell c, whose surrounding
 * samples near holds (have: they fit). */
static void add_cell(wpd_eliminate *e, const block_order *o, size_t first, size_t end,
                     const int64_t c[3], gathered *near, int have, uint32_t *nearest)
{
    const wpd_grid *g = &e->grid;
    int lanes = have && near->n >= 3;
    for (size_t k0 = first; k0 < end; k0 += POINT_LANES) {
        int m = end - k0 < POINT_LANES ? (int)(end - k0) : POINT_LANES;
        float px[POINT_LANES], py[POINT_LANES], pz[POINT_LANES];
        float a0[POINT_LANES], a1[POINT_LANES], a2[POINT_LANES];
        if (lanes) {
            for (int k = 0; k < POINT_LANES; k++) {
                float f[3];
                wpd_block_local(g, near, o->xyz + 3 * (k0 + (size_t)(k < m ? k : 0)), f);
                px[k] = f[0], py[k] = f[1], pz[k] = f[2];
            }
            three_smallest(near, px, py, pz, a0, a1, a2);
        }
        for (int k = 0; k < m; k++) {
            size_t at = k0 + (size_t)k;
            const double *p = o->xyz + 3 * at;
            uint32_t *out = nearest ? nearest + o->val[at] : NULL;
            /* The tags move each value by less than 2^-14 of it (by less
             * than FLT_MIN, far below the slack, for a clamped zero). */
            if (!lanes || !(a2[k] - a1[k] > FLOAT_SLACK + 0x1p-12f * a2[k])) {
                add_one(e, near, have, c, p, out);
                continue;
            }
            uint32_t idx[2] = {UINT32_MAX, UINT32_MAX};
            double d2[2] = {INFINITY, INFINITY};
            offer(near, (int)tag_of(a0[k]), p, d2, idx);
            offer(near, (int)tag_of(a1[k]), p, d2, idx);
            /* p outside the block, or a sample beyond it as near */
            if (!wpd_block_holds(g, c, p, d2[1])) {
                add_one(e, NULL, 0, c, p, out);
                continue;
            }
            add_found(e, 2, idx, d2, out);
        }
    }
}

void wpd_eliminate_add_points(wpd_eliminate *e, const double *pts, const uint8_t *skip,
                              size_t npts, int threads, uint32_t *nearest)
{
    /* Every point handed to add_one gets its own entry there; only points
     * that are not (skipped, or no sample left) need the mark first. */
    if (nearest && (skip || e->live == 0))
        for (size_t i = 0; i < npts; i++)
            nearest[i] = WPD_ELIMINATE_NO_NEAREST;
    if (e->live == 0)
        return;
    size_t nblocks = (npts + QUERY_BLOCK - 1) / QUERY_BLOCK;
    /* Queries of one cell share the samples around it (gathered once): the
     * per-query column look-ups were most of the time. Without memory for
     * the order, each point is searched on its own (same result). */
#pragma omp parallel num_threads(threads > 0 ? threads : e->threads)
    {
        gathered *near = malloc(sizeof *near);
        block_order *o = near ? malloc(sizeof *o) : NULL;
#pragma omp for schedule(dynamic, 1)
        for (size_t b = 0; b < nblocks; b++) {
            size_t first = b * QUERY_BLOCK;
            size_t n = npts - first < QUERY_BLOCK ? npts - first : QUERY_BLOCK;
            int64_t c[3] = {0, 0, 0};
            if (!o) {
                for (size_t i = first; i < first + n; i++)
                    if (!skip || !skip[i])
                        add_one(e, NULL, 0, c, pts + 3 * i, nearest ? nearest + i : NULL);
                continue;
            }
            size_t m = order_block(&e->grid, pts, skip, first, n, o);
            for (size_t k = 0; k < m;) {
                size_t end = k + 1;
                while (end < m && o->key[end] == o->key[k])
                    end++;
                wpd_grid_cell_of(&e->grid, o->xyz + 3 * k, c);
                int have = wpd_block_gather(&e->grid, c, GATHER_MAX, UINT32_MAX, near);
                add_cell(e, o, k, end, c, near, have, nearest);
                k = end;
            }
        }
        free(o);
        free(near);
    }
}

double wpd_eliminate_nearest(const wpd_eliminate *e, uint32_t s)
{
    uint32_t idx[1];
    double d2[1];
    int got = wpd_knn(&e->grid, e->xyz + 3 * (size_t)s, 1, s, e->reach, e->grid.cell, idx, d2);
    return got ? sqrt(d2[0]) : e->reach;
}

void wpd_eliminate_nearest_all(const wpd_eliminate *e, double *nn)
{
    size_t m = e->n ? e->n : 1;
    uint32_t *idx = malloc(m * sizeof *idx);
    double *d2 = malloc(m * sizeof *d2);
    uint8_t *count = malloc(m);
    wpd_error ignored;
    if (idx && d2 && count &&
        wpd_knn_batch(&e->grid, e->n, 1, e->reach, NULL, idx, d2, count, e->threads, NULL,
                      &ignored) == 0) {
#pragma omp parallel for num_threads(e->threads) schedule(static)
        for (size_t i = 0; i < e->live; i++) {
            uint32_t s = e->live_idx[i];
            nn[s] = count[s] ? sqrt(d2[s]) : e->reach;
        }
    } else {
        /* Without memory for the batch, one search a sample: the same. */
#pragma omp parallel for num_threads(e->threads) schedule(dynamic, 1024)
        for (size_t i = 0; i < e->live; i++)
            nn[e->live_idx[i]] = wpd_eliminate_nearest(e, e->live_idx[i]);
    }
    free(idx);
    free(d2);
    free(count);
}

/* The squared cost, relative to the sample's own radius (a sample of
 * radius r/2 costs 4 times its squared hole): which samples a sweep may
 * take (the candidates below). */
static double cost_of(const wpd_eliminate *e, uint32_t s)
{
    return wpd_eliminate_cost_of(e->cost[s], e->half && e->half[s]);
}

/* The order of deletion among the candidates: cost_of times the sample's
 * crowding factor of the sweep (crowding()). */
static double rank_of(const wpd_eliminate *e, const double *crowd, uint32_t s)
{
    return cost_of(e, s) * crowd[s];
}

/* 1 if no sample marked in taken lies within twice the larger of its cost
 * and s's (taken_cost: the largest squared cost taken so far). */
static int clear_around(const wpd_eliminate *e, const uint8_t *taken, double taken_cost,
                        uint32_t s)
{
    const wpd_grid *g = &e->grid;
    const double *q = e->xyz + 3 * (size_t)s;
    double own = wpd_bits_double(e->cost[s]);
    double reach2 = 4 * (own > taken_cost ? own : taken_cost);
    int64_t lo[3], hi[3];
    if (!wpd_grid_box(g, q, sqrt(reach2), lo, hi))
        return 1;
    for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t a = lo[0]; a <= hi[0]; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
            for (uint32_t k = sb; k < se; k++) {
                if (!taken[g->id[k]])
                    continue;
                const double *p = g->xyz + 3 * (size_t)k;
                double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
                double theirs = wpd_bits_double(e->cost[g->id[k]]);
                if (dx * dx + dy * dy + dz * dz <= 4 * (own > theirs ? own : theirs))
                    return 0;
            }
        }
    return 1;
}

/* The live samples in (cost_of, index) order into val[0..live-1], their
 * costs' bits in key (costs are >= 0, so the integer order of the bits is
 * the numeric order; one stable radix sort of the ascending indices). key
 * and val hold 2 x live entries (the upper halves are scratch). */
static void by_cost(const wpd_eliminate *e, uint64_t *key, uint32_t *val)
{
    size_t m = e->live;
    uint64_t top = 0;
    for (size_t i = 0; i < m; i++) {
        val[i] = e->live_idx[i];
        key[i] = wpd_double_bits(cost_of(e, val[i]));
        top |= key[i];
    }
    int bits = 1;
    while (bits < 64 && top >> bits)
        bits++;
    wpd_radix_sort_u64(key, val, m, bits, key + m, val + m);
}

/* cand[0..nc-1] in (rank_of, index) order: by index, then stably by the
 * ranks' bits (>= 0: integer order is numeric order). key: scratch of
 * 2 x nc entries; cand holds 2 x nc (the upper half is scratch). */
static void by_rank(const wpd_eliminate *e, const double *crowd, uint32_t *cand, size_t nc,
                    uint64_t *key)
{
    for (size_t i = 0; i < nc; i++)
        key[i] = cand[i];
    wpd_radix_sort_u64(key, cand, nc, 32, key + nc, cand + nc);
    uint64_t top = 0;
    for (size_t i = 0; i < nc; i++) {
        key[i] = wpd_double_bits(rank_of(e, crowd, cand[i]));
        top |= key[i];
    }
    int bits = 1;
    while (bits < 64 && top >> bits)
        bits++;
    wpd_radix_sort_u64(key, cand, nc, bits, key + nc, cand + nc);
}

/* The k-th smallest of a[0..m-1] (k < m; a is reordered): the value
 * qsort would put at a[k], in linear expected time (Hoare's selection). */
static double kth_smallest(double *a, size_t m, size_t k)
{
    size_t lo = 0, hi = m - 1;
    while (lo < hi) {
        double pivot = a[lo + (hi - lo) / 2];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (a[i] < pivot)
                i++;
            while (a[j] > pivot)
                j--;
            if (i <= j) {
                double t = a[i];
                a[i] = a[j], a[j] = t;
                i++;
                if (j == 0)
                    break;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return a[k];
    }
    return a[k];
}

/* Among candidates of similar cost, the crowded go first (as in Yuksel's
 * weighted sample elimination): a sample whose nearest live sample lies
 * closer than the median of that distance over the live samples, d < med,
 * has its rank scaled by (d / med)^2; the others keep their cost as rank.
 * Only the order among the candidates changes, not which samples are
 * candidates (their cost bound, below), so no larger hole can open than
 * before: on the 18 quality cases (docs/benchmarks.md) the Hausdorff
 * distance grew by at most 0.8 % and the local CV moved by at most 0.6 %
 * (NC Raleigh 10 K: 0.0944 -> 0.0941 without smoothing; docs/algorithm.md,
 * section 3). Global over the live samples and by coordinates only: the
 * same for any threads or tiles. tmp: room for e->live doubles (reordered).
 * Returns 0. */
static int crowding(const wpd_eliminate *e, double *crowd, double *tmp)
{
    wpd_eliminate_nearest_all(e, crowd);
    for (size_t i = 0; i < e->live; i++)
        tmp[i] = crowd[e->live_idx[i]];
    if (e->live == 0)
        return 0;
    double med = kth_smallest(tmp, e->live, e->live / 2);
    for (size_t i = 0; i < e->live; i++) {
        uint32_t s = e->live_idx[i];
        crowd[s] = wpd_eliminate_crowd_factor(crowd[s], med);
    }
    return 0;
}

long wpd_eliminate_sweep(wpd_eliminate *e, size_t target, wpd_error *err)
{
    if (e->live <= target)
        return 0;
    size_t quota = e->live - target, m = e->live;
    uint64_t *key = malloc(2 * m * sizeof *key);
    uint32_t *cand = malloc(2 * m * sizeof *cand);
    uint8_t *taken = calloc(e->n, 1);
    double *crowd = malloc((e->n ? e->n : 1) * sizeof *crowd);
    double *tmp = malloc((m ? m : 1) * sizeof *tmp);
    if (!key || !cand || !taken || !crowd || !tmp) {
        free(key), free(cand), free(taken), free(crowd), free(tmp);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count");
    }
    crowding(e, crowd, tmp);
    by_cost(e, key, cand);
    /* Candidates: the samples up to the cost of rank quota + min(quota,
     * m / 20). Up to rank quota alone, crowded neighbourhoods (whose
     * cheapest samples lie close together) left most of the quota to later
     * sweeps (5 instead of 1 for NC Raleigh 105 K -> 100 K, for the same
     * Hausdorff); with no bound at all, a large surplus (2.2 n) took
     * samples that opened holes (Hausdorff 0.0033 of the diagonal against
     * 0.0013). */
    size_t rank = quota + (quota < m / 20 ? quota : m / 20);
    uint64_t tau = key[(rank < m ? rank : m) - 1];
    size_t nc = 0;
    while (nc < m && key[nc] <= tau)
        nc++;
    by_rank(e, crowd, cand, nc, key);
    /* In (rank, index) order, each candidate clear of those taken before:
     * no two deletions of the sweep touch each other's regions. */
    size_t deleted = 0;
    double taken_cost = 0;
    for (size_t i = 0; i < nc && deleted < quota; i++)
        if (clear_around(e, taken, taken_cost, cand[i])) {
            taken[cand[i]] = 1;
            taken_cost = fmax(taken_cost, wpd_bits_double(e->cost[cand[i]]));
            e->alive[cand[i]] = 0;
            deleted++;
        }
    e->live -= deleted;
    free(key), free(cand), free(taken), free(crowd), free(tmp);
    return (long)deleted;
}
