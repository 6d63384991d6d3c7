/* knn.c - growing-box kNN search on the sorted-cell grid. */
#include "core/knn.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>

/* The best candidates so far, sorted by (d2, id). */
typedef struct knn_heap {
    int k, cnt;
    uint32_t self;
    double max_d2;
    double bound;   /* no point farther than this can enter: max_d2 (or, in a
                       hinted first box, the hint squared), or the k-th
                       distance once full */
    double d2[WPD_KNN_MAX];
    uint32_t id[WPD_KNN_MAX];
    uint32_t slot[WPD_KNN_MAX];
} knn_heap;

static inline int better(double da, uint32_t ia, double db, uint32_t ib)
{
    return da < db || (da == db && ia < ib);
}

/* Offers a point with d2 <= h->bound (farther ones cannot enter). */
static inline void offer(knn_heap *h, double d2, uint32_t id, uint32_t slot)
{
    if (id == h->self)
        return;
    if (h->cnt == h->k && !better(d2, id, h->d2[h->k - 1], h->id[h->k - 1]))
        return;
    int j = h->cnt < h->k ? h->cnt++ : h->k - 1;
    while (j > 0 && better(d2, id, h->d2[j - 1], h->id[j - 1])) {
        h->d2[j] = h->d2[j - 1];
        h->id[j] = h->id[j - 1];
        h->slot[j] = h->slot[j - 1];
        j--;
    }
    h->d2[j] = d2;
    h->id[j] = id;
    h->slot[j] = slot;
    if (h->cnt == h->k && h->d2[h->k - 1] < h->bound)
        h->bound = h->d2[h->k - 1];
}

static void scan_slots(const wpd_grid *g, const double q[3], uint32_t b, uint32_t e,
                       knn_heap *h)
{
    const double *p = g->xyz + 3 * (size_t)b;
    for (uint32_t s = b; s < e; s++, p += 3) {
        double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        double d2 = dx * dx + dy * dy + dz * dz;
        if (d2 <= h->bound) /* most points of a scanned box are rejected here */
            offer(h, d2, g->id[s], s);
    }
}

/* Offers the points of the cells of row b (along axis[1]) whose
 * columns lie in [lo[0], hi[0]] and whose index along axis[2] lies in
 * [lo[2], hi[2]]; dense column index only. */
static void scan_row(const wpd_grid *g, const double q[3], const int64_t lo[3], const int64_t hi[3],
                     int64_t b, knn_heap *h)
{
    uint64_t da = (uint64_t)g->dim[g->axis[0]];
    uint64_t col = (uint64_t)lo[0] + da * (uint64_t)b;
    uint32_t r = g->col_run[col], re = g->col_run[col + (uint64_t)(hi[0] - lo[0]) + 1];
    while (r < re) {
        while (r < re && ((int64_t)g->run_c[r] < lo[2] || (int64_t)g->run_c[r] > hi[2]))
            r++;
        uint32_t first = r;
        while (r < re && (int64_t)g->run_c[r] >= lo[2] && (int64_t)g->run_c[r] <= hi[2])
            r++;
        if (r > first)
            scan_slots(g, q, g->run_start[first], g->run_start[r], h);
    }
}

/* Offers every point of the cells overlapping [q - rho, q + rho]; when the
 * box spans more columns than there are points, every point instead.
 * Returns 1 if every point of the grid was offered. */
static int scan_box(const wpd_grid *g, const double q[3], double rho, knn_heap *h)
{
    int64_t lo[3], hi[3];
    if (!wpd_grid_box(g, q, rho, lo, hi))
        return 0;
    double cols = (double)(hi[0] - lo[0] + 1) * (double)(hi[1] - lo[1] + 1);
    if (cols > (double)g->n) {
        scan_slots(g, q, 0, (uint32_t)g->n, h);
        return 1;
    }
    int all = 1;
    for (int k = 0; k < 3; k++)
        if (lo[k] > 0 || hi[k] < g->dim[g->axis[k]] - 1)
            all = 0;
    if (g->col_run) {
        /* Dense columns: the columns lo[0]..hi[0] of one row are consecutive
         * runs, so a row is read as one stream of runs and slots instead of
         * a lookup per column. The row of q first: its points are the
         * nearest, so the bound is tight early (the k best by distance and
         * index do not depend on the order of the offers). */
        int64_t cb = wpd_grid_coord(g, g->axis[1], q[g->axis[1]]);
        if (cb >= lo[1] && cb <= hi[1])
            scan_row(g, q, lo, hi, cb, h);
        for (int64_t b = lo[1]; b <= hi[1]; b++)
            if (b != cb)
                scan_row(g, q, lo, hi, b, h);
        return all;
    }
    /* The column of q first: its points are the nearest, so the bound is
     * tight early and fewer farther points get offered (the k best by
     * distance and index do not depend on the order of the offers). */
    int64_t ca = wpd_grid_coord(g, g->axis[0], q[g->axis[0]]);
    int64_t cb = wpd_grid_coord(g, g->axis[1], q[g->axis[1]]);
    int centre = ca >= lo[0] && ca <= hi[0] && cb >= lo[1] && cb <= hi[1];
    if (centre) {
        uint32_t sb, se;
        wpd_grid_column_slots(g, ca, cb, lo[2], hi[2], &sb, &se);
        scan_slots(g, q, sb, se, h);
    }
    for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t a = lo[0]; a <= hi[0]; a++) {
            if (centre && a == ca && b == cb)
                continue;
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
            scan_slots(g, q, sb, se, h);
        }
    return all;
}

/* Scans boxes centred on q, growing until the k-th nearest point lies
 * within the box's half-width rho: every point outside the box is farther
 * than rho, so the answer is exact. A hint is the caller's guess of the
 * k-th distance, so the first box is scanned with the list's bound at
 * rho: the points in its corners, farther than rho, never enter the
 * sorted list. When fewer than k lie within rho, the box is scanned again
 * without that bound, grown unless it held every point. */
static int knn_search(const wpd_grid *g, const double q[3], int k, uint32_t self,
                      double max_dist, double hint, knn_heap *h)
{
    h->k = k < 1 ? 1 : k > WPD_KNN_MAX ? WPD_KNN_MAX : k;
    h->self = self;
    h->max_d2 = isinf(max_dist) ? INFINITY : max_dist * max_dist;
    double rho = hint > 0 ? hint : g->cell;
    if (rho > max_dist)
        rho = max_dist;
    int tight = hint > 0 && rho * rho < h->max_d2;
    for (;;) {
        h->cnt = 0;
        h->bound = tight ? rho * rho : h->max_d2;
        if (g->n == 0)
            return 0;
        int all = scan_box(g, q, rho, h);
        if (tight) {
            tight = 0;
            if (h->cnt == h->k)
                return h->cnt; /* all k within rho */
            if (all)
                continue;
        } else if (all || rho >= max_dist) {
            return h->cnt;
        } else if (h->cnt == h->k) {
            double dk = sqrt(h->d2[h->k - 1]);
            if (dk <= rho)
                return h->cnt;
            rho = dk > 1.0001 * rho ? dk : 1.0001 * rho; /* enough next time */
            if (rho > max_dist)
                rho = max_dist;
            continue;
        }
        rho *= 2;
        if (rho > max_dist)
            rho = max_dist;
    }
}

/* knn_search, its answer written as slots (want_slots) or source ids. */
static int knn_answer(const wpd_grid *g, const double q[3], int k, uint32_t self,
                      double max_dist, double hint, int want_slots, uint32_t *out, double *d2)
{
    knn_heap h;
    int cnt = knn_search(g, q, k, self, max_dist, hint, &h);
    for (int j = 0; j < cnt; j++) {
        out[j] = want_slots ? h.slot[j] : h.id[j];
        if (d2)
            d2[j] = h.d2[j];
    }
    return cnt;
}

int wpd_knn(const wpd_grid *g, const double q[3], int k, uint32_t self,
            double max_dist, double hint, uint32_t *idx, double *d2)
{
    return knn_answer(g, q, k, self, max_dist, hint, 0, idx, d2);
}

int wpd_knn_slots(const wpd_grid *g, const double q[3], int k, uint32_t self,
                  double max_dist, double hint, uint32_t *slot, double *d2)
{
    return knn_answer(g, q, k, self, max_dist, hint, 1, slot, d2);
}

void wpd_knn_many(const wpd_grid *g, const double *qxyz, const uint32_t *self,
                  size_t nq, int k, double max_dist, uint32_t *idx, double *d2,
                  uint8_t *count, int threads)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
    for (size_t i = 0; i < nq; i++) {
        int got = wpd_knn(g, qxyz + 3 * i, k, self ? self[i] : WPD_NO_SELF, max_dist, 0,
                          idx + i * (size_t)k, d2 ? d2 + i * (size_t)k : NULL);
        count[i] = (uint8_t)got;
    }
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double wpd_knn_median_kth(const wpd_grid *g, int k)
{
    size_t n = g->n;
    if (n < 256)
        return 0;
    enum { PROBES = 64 };
    double dk[PROBES];
    int m = 0;
    for (int i = 0; i < PROBES; i++) {
        size_t s = (size_t)((2 * i + 1) * (double)n / (2 * PROBES));
        knn_heap h;
        int got = knn_search(g, g->xyz + 3 * s, k, g->id[s], INFINITY, 0, &h);
        if (got == h.k)
            dk[m++] = sqrt(h.d2[got - 1]);
    }
    if (m < PROBES / 2)
        return 0;
    qsort(dk, (size_t)m, sizeof *dk, cmp_double);
    return dk[m / 2];
}

int wpd_grid_build_knn(wpd_grid *g, const double *xyz, const uint32_t *subset, size_t n,
                       int k, double cell_guess, int threads, wpd_error *err)
{
    if (wpd_grid_build(g, xyz, subset, n, cell_guess, threads, err) < 0)
        return -1;
    double median = wpd_knn_median_kth(g, k);
    if (median > 0 && (median > 1.6 * g->cell || median < 0.4 * g->cell))
        return wpd_grid_build(g, xyz, subset, n, median, threads, err);
    return 0;
}
