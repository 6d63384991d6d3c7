/* sharp.c - the sharp-feature detector (sharp.h): bounded, ordered
 * neighbourhoods, the local spacing, and the crease test on each point. */
#include "wpd/sharp.h"

#include <math.h>
#include <omp.h>
#include <string.h>

#include "core/knn.h"
#include "wpd/crease.h"

/* ---- Bounded neighbourhoods ---------------------------------------------- */

/* The best neighbours so far, sorted by (d2, x, y, z). */
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

static void offer(capped_best *h, double d2, const double *p, double cap2)
{
    if (d2 >= cap2)
        return;
    if (h->cnt == h->k && !before(d2, p, h->d2[h->k - 1], h->p[h->k - 1]))
        return;
    int j = h->cnt < h->k ? h->cnt++ : h->k - 1;
    while (j > 0 && before(d2, p, h->d2[j - 1], h->p[j - 1])) {
        h->d2[j] = h->d2[j - 1];
        h->p[j] = h->p[j - 1];
        j--;
    }
    h->d2[j] = d2;
    h->p[j] = p;
    if (h->cnt == h->k)
        h->bound = h->d2[h->k - 1];
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
 * Boxes grow from one cell until the k-th distance is within the box's
 * half-width (every point outside is farther), the box reaches cap (every
 * point closer than cap has been seen) or covers the grid. */
static int capped_knn(const wpd_grid *g, const double q[3], int k, double cap, capped_best *h)
{
    double cap2 = cap * cap;
    double rho = g->cell < cap ? g->cell : cap;
    h->k = k;
    for (;;) {
        h->cnt = 0;
        h->bound = cap2;
        int all = offer_box(g, q, rho, cap2, h);
        if (all || rho >= cap || (h->cnt == k && h->d2[k - 1] <= rho * rho))
            return h->cnt;
        rho *= 2;
        if (h->cnt == k && sqrt(h->d2[k - 1]) > rho)
            rho = sqrt(h->d2[k - 1]);
        if (rho > cap)
            rho = cap;
    }
}

/* The label of the point at q: its neighbourhood (the nearest points
 * closer than cap), the spacing from it, the crease test on the nearest
 * of them within WPD_SHARP_REACH spacings. */
static int label_point(const wpd_grid *g, const double q[3], double cap, wpd_crease_verdict *why)
{
    capped_best h;
    int got = capped_knn(g, q, WPD_KNN_MAX, cap, &h);
    if (got <= WPD_SHARP_SPACING_K) {
        *why = WPD_CREASE_SMALL_FACE;
        return 0;
    }
    /* k points within d_k of a point of a surface: a disc of k / (pi d_k^2)
     * points per unit area; the spacing is one over its square root. */
    double spacing = sqrt(h.d2[WPD_SHARP_SPACING_K] * M_PI / WPD_SHARP_SPACING_K);
    double reach2 = WPD_SHARP_REACH * WPD_SHARP_REACH * spacing * spacing;
    double pts[3 * WPD_KNN_MAX];
    int m = 0;
    for (; m < got && h.d2[m] <= reach2; m++)
        memcpy(pts + 3 * m, h.p[m], 3 * sizeof(double));
    *why = wpd_crease_test(pts, m, q, spacing);
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
