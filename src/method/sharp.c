/* sharp.c - the sharp-feature detector (sharp.h): bounded, ordered
 * neighbourhoods, the local spacing, and the crease test on each point. */
#include "method/sharp.h"

#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/knn.h"
#include "method/crease.h"

/* ---- Bounded neighbourhoods ---------------------------------------------- */

/* The best neighbours so far: a max-heap by (d2, x, y, z) while the box
 * grows (an offer costs log k, not k), sorted ascending at the end. */
typedef struct capped_best {
    int k, cnt;
    double bound;   /* squared distance no new point may reach or exceed:
                       cap^2, or the k-th distance once full (ties at it
                       can still enter, hence <= below) */
    double d2[WPD_KNN_MAX];
    const double *p[WPD_KNN_MAX];
} capped_best;

/* (d2, coordinates) order: equal distances are ordered by the points
 * themselves, so the answer does not depend on indices or slots. Two points
 * equal in all four are interchangeable. */
static inline int before(double da, const double *pa, double db, const double *pb)
{
    if (da != db)
        return da < db;
    for (int a = 0; a < 3; a++)
        if (pa[a] != pb[a])
            return pa[a] < pb[a];
    return 0;
}

static inline void swap_entries(capped_best *h, int i, int j)
{
    double d = h->d2[i];
    const double *p = h->p[i];
    h->d2[i] = h->d2[j], h->p[i] = h->p[j];
    h->d2[j] = d, h->p[j] = p;
}

/* Restores the heap below entry i of the first n entries. */
static void sift_down(capped_best *h, int i, int n)
{
    for (;;) {
        int c = 2 * i + 1;
        if (c >= n)
            return;
        if (c + 1 < n && before(h->d2[c], h->p[c], h->d2[c + 1], h->p[c + 1]))
            c++;
        if (!before(h->d2[i], h->p[i], h->d2[c], h->p[c]))
            return;
        swap_entries(h, i, c);
        i = c;
    }
}

static void offer(capped_best *h, double d2, const double *p, double cap2)
{
    if (d2 >= cap2)
        return;
    if (h->cnt < h->k) { /* sift the new last entry up */
        int i = h->cnt++;
        h->d2[i] = d2, h->p[i] = p;
        while (i > 0 && before(h->d2[(i - 1) / 2], h->p[(i - 1) / 2], d2, p)) {
            swap_entries(h, i, (i - 1) / 2);
            i = (i - 1) / 2;
        }
    } else if (before(d2, p, h->d2[0], h->p[0])) { /* replace the largest */
        h->d2[0] = d2, h->p[0] = p;
        sift_down(h, 0, h->cnt);
    } else {
        return;
    }
    if (h->cnt == h->k)
        h->bound = h->d2[0];
}

/* The heap in ascending (d2, x, y, z) order. */
static void sort_best(capped_best *h)
{
    for (int n = h->cnt; n > 1; n--) {
        swap_entries(h, 0, n - 1);
        sift_down(h, 0, n - 1);
    }
}

/* Offers every grid point in the cells overlapping [q - rho, q + rho];
 * returns 1 when those cells are the whole grid. */
static int offer_box(const wpd_grid *g, const double q[3], double rho, double cap2,
                     capped_best *h)
{
    int64_t lo[3], hi[3];
    if (!wpd_grid_box(g, q, rho, lo, hi))
        return 0;
    int all = 1;
    for (int a = 0; a < 3; a++)
        if (lo[a] > 0 || hi[a] < g->dim[g->axis[a]] - 1)
            all = 0;
    for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t a = lo[0]; a <= hi[0]; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
            const double *p = g->xyz + 3 * (size_t)sb;
            for (uint32_t s = sb; s < se; s++, p += 3) {
                double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
                double d2 = dx * dx + dy * dy + dz * dz;
                if (d2 <= h->bound)
                    offer(h, d2, p, cap2);
            }
        }
    return all;
}

/* The k nearest grid points closer than cap to q, in (d2, x, y, z) order.
 * Boxes grow from half a cell until the k-th distance is within the box's
 * half-width (every point outside is farther), the box reaches cap (every
 * point closer than cap has been seen) or covers the grid. */
static int capped_knn(const wpd_grid *g, const double q[3], int k, double cap, capped_best *h)
{
    double cap2 = cap * cap;
    double rho = g->cell / 2 < cap ? g->cell / 2 : cap;
    h->k = k;
    for (;;) {
        h->cnt = 0;
        h->bound = cap2;
        int all = offer_box(g, q, rho, cap2, h);
        if (all || rho >= cap || (h->cnt == k && h->d2[0] <= rho * rho)) {
            sort_best(h);
            return h->cnt;
        }
        rho *= 2;
        if (h->cnt == k && sqrt(h->d2[0]) > rho)
            rho = sqrt(h->d2[0]);
        if (rho > cap)
            rho = cap;
    }
}

/* The k nearest grid points closer than radius to q, in (d2, x, y, z)
 * order: one box, as every such point lies in it. */
static int within(const wpd_grid *g, const double q[3], int k, double radius, capped_best *h)
{
    h->k = k;
    h->cnt = 0;
    h->bound = radius * radius;
    offer_box(g, q, radius, radius * radius, h);
    sort_best(h);
    return h->cnt;
}

/* The nearest points (up to WPD_KNN_MAX) closer than both cap and
 * WPD_SHARP_REACH spacings to q, the spacing from the
 * WPD_SHARP_SPACING_K-th neighbour closer than cap. Mostly one box query:
 * the first, of a radius chosen for speed only (about a grid cell), gives
 * the spacing and, when it reaches as far or is full, the answer. Returns
 * the points (0 when fewer than WPD_SHARP_SPACING_K + 1 lie within cap). */
static int neighbourhood(const wpd_grid *g, const double q[3], double cap, capped_best *h,
                         double *spacing)
{
    double first = fmin(cap, 1.2 * g->cell);
    int got = within(g, q, WPD_KNN_MAX, first, h);
    double d2k;
    if (got > WPD_SHARP_SPACING_K) {
        d2k = h->d2[WPD_SHARP_SPACING_K];
    } else if (capped_knn(g, q, WPD_SHARP_SPACING_K + 1, cap, h) > WPD_SHARP_SPACING_K) {
        d2k = h->d2[WPD_SHARP_SPACING_K];
        got = 0; /* h holds the spacing query now */
    } else {
        return 0;
    }
    /* k points within d_k of a point of a surface: a disc of k / (pi d_k^2)
     * points per unit area; the spacing is one over its square root. */
    *spacing = sqrt(d2k * M_PI / WPD_SHARP_SPACING_K);
    double reach = fmin(WPD_SHARP_REACH * *spacing, cap);
    if (reach > first && got < WPD_KNN_MAX)
        return within(g, q, WPD_KNN_MAX, reach, h);
    int m = 0; /* the first query's points within reach: a prefix */
    while (m < got && h->d2[m] < reach * reach)
        m++;
    return m;
}

/* The label of the point at q: the crease test on its neighbourhood. */
static int label_point(const wpd_grid *g, const double q[3], double cap, wpd_crease_verdict *why)
{
    capped_best h;
    double spacing;
    int got = neighbourhood(g, q, cap, &h, &spacing);
    if (!got) {
        *why = WPD_CREASE_SMALL_FACE;
        return 0;
    }
    double pts[3 * WPD_KNN_MAX];
    for (int j = 0; j < got; j++)
        memcpy(pts + 3 * j, h.p[j], 3 * sizeof(double));
    *why = wpd_crease_test(pts, got, q, spacing);
    return *why == WPD_CREASE_ON;
}

void wpd_detect_sharp_capped(const wpd_grid *surface, size_t begin, size_t end, double cap,
                             uint8_t *edge, int threads)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
    size_t slots = surface->n;
    /* Each label is computed on its own from its neighbourhood: any
     * schedule gives the same labels. */
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1024)
    for (size_t s = 0; s < slots; s++) {
        uint32_t id = surface->id[s];
        if (id < begin || id >= end)
            continue;
        wpd_crease_verdict why;
        edge[id] = (uint8_t)label_point(surface, surface->xyz + 3 * s, cap, &why);
    }
}

void wpd_sharp_verdicts(const wpd_grid *surface, double cap, uint8_t *verdict, int threads)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
    size_t slots = surface->n;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1024)
    for (size_t s = 0; s < slots; s++) {
        wpd_crease_verdict why;
        label_point(surface, surface->xyz + 3 * s, cap, &why);
        verdict[surface->id[s]] = (uint8_t)why;
    }
}
