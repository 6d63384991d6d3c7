/* sharp.c - the sharp-feature detector (sharp.h): bounded, ordered
 * neighbourhoods, the local spacing, and the crease test on each point. */
#include "method/sharp.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
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

/* The spacing from the squared distance d2k of the WPD_SHARP_SPACING_K-th
 * neighbour. */
static void spacing_of(double d2k, double *spacing)
{
    /* k points within d_k of a point of a surface: a disc of k / (pi d_k^2)
     * points per unit area; the spacing is one over its square root. */
    *spacing = sqrt(d2k * M_PI / WPD_SHARP_SPACING_K);
}

/* The neighbourhood (below) with no memory but the heap's: for when the
 * collection buffer cannot grow. */
static int heap_neighbourhood(const wpd_grid *g, const double q[3], double cap, double *pts,
                              double *spacing)
{
    capped_best h;
    if (capped_knn(g, q, WPD_SHARP_SPACING_K + 1, cap, &h) <= WPD_SHARP_SPACING_K)
        return 0;
    spacing_of(h.d2[WPD_SHARP_SPACING_K], spacing);
    int m = within(g, q, WPD_KNN_MAX, fmin(WPD_SHARP_REACH * *spacing, cap), &h);
    for (int j = 0; j < m; j++)
        memcpy(pts + 3 * j, h.p[j], 3 * sizeof(double));
    return m;
}

/* ---- Neighbourhoods by collection ---------------------------------------
 *
 * The common case: every grid point closer than some radius collected with
 * its squared distance, then the nearest selected and sorted. Cheaper than
 * the heap above (an offer there costs log k comparisons of four keys; here
 * most points cost one distance and one store), and the same answer: the
 * nearest points in (d2, x, y, z) order are a set and an order that do not
 * depend on how they were found. */

/* A collected point. */
typedef struct cand {
    double d2;
    const double *p;
} cand;

/* A collection buffer (grows; freed by the caller). */
typedef struct cand_list {
    cand *a;
    size_t n, cap;
} cand_list;

/* Per-thread buffers: a point's neighbourhood, and the points around a
 * labelled one whose verdicts may support it (the support test runs
 * crease tests of its own, which collect neighbourhoods). */
typedef struct sharp_scratch {
    cand_list ball, near;
    double hint; /* the last reach: the next point's is most often alike */
} sharp_scratch;

static void scratch_free(sharp_scratch *sc)
{
    free(sc->ball.a);
    free(sc->near.a);
}

static inline int cand_before(const cand *a, const cand *b)
{
    return before(a->d2, a->p, b->d2, b->p);
}

static inline void cand_swap(cand *a, cand *b)
{
    cand t = *a;
    *a = *b;
    *b = t;
}

/* Median of three as pivot, moved to a[0]. */
static void pivot_first(cand *a, size_t n)
{
    cand *m = a + n / 2, *z = a + n - 1;
    if (cand_before(m, a))
        cand_swap(m, a);
    if (cand_before(z, m)) {
        cand_swap(z, m);
        if (cand_before(m, a))
            cand_swap(m, a);
    }
    cand_swap(a, m);
}

/* Partitions a[0..n) around the pivot a[0]; returns its final index (the
 * order is total, so every entry before it is smaller, after it larger,
 * but for identical points, which are interchangeable). */
static size_t partition(cand *a, size_t n)
{
    size_t lo = 1, hi = n - 1;
    for (;;) {
        while (lo <= hi && cand_before(&a[lo], &a[0]))
            lo++;
        while (lo <= hi && cand_before(&a[0], &a[hi]))
            hi--;
        if (lo >= hi)
            break;
        cand_swap(&a[lo++], &a[hi--]);
    }
    cand_swap(&a[0], &a[lo - 1]);
    return lo - 1;
}

static void insertion_sort(cand *a, size_t n)
{
    for (size_t i = 1; i < n; i++) {
        cand x = a[i];
        size_t j = i;
        while (j > 0 && cand_before(&x, &a[j - 1])) {
            a[j] = a[j - 1];
            j--;
        }
        a[j] = x;
    }
}

/* The k smallest of a[0..n) into a[0..k), unordered (k < n). */
static void select_smallest(cand *a, size_t n, size_t k)
{
    while (n > 16) {
        pivot_first(a, n);
        size_t m = partition(a, n);
        if (m == k || m + 1 == k)
            return;
        if (m > k) {
            n = m;
        } else {
            a += m + 1;
            n -= m + 1;
            k -= m + 1;
        }
    }
    insertion_sort(a, n);
}

static void sort_cands(cand *a, size_t n)
{
    while (n > 16) {
        pivot_first(a, n);
        size_t m = partition(a, n);
        /* recurse into the smaller side, loop on the larger */
        if (m < n - m - 1) {
            sort_cands(a, m);
            a += m + 1;
            n -= m + 1;
        } else {
            sort_cands(a + m + 1, n - m - 1);
            n = m;
        }
    }
    insertion_sort(a, n);
}

/* Collects every grid point closer than rho to q into sc (replacing what
 * it held). Returns 0, or -1 when the buffer cannot grow. */
static int collect(const wpd_grid *g, const double q[3], double rho, cand_list *sc)
{
    sc->n = 0;
    int64_t lo[3], hi[3];
    if (!wpd_grid_box(g, q, rho, lo, hi))
        return 0;
    double rho2 = rho * rho;
    for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t a = lo[0]; a <= hi[0]; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
            if (sc->n + (se - sb) > sc->cap) {
                size_t cap = 2 * (sc->n + (se - sb)) + 256;
                cand *grown = realloc(sc->a, cap * sizeof *grown);
                if (!grown)
                    return -1;
                sc->a = grown;
                sc->cap = cap;
            }
            cand *out = sc->a + sc->n;
            const double *p = g->xyz + 3 * (size_t)sb;
            for (uint32_t s = sb; s < se; s++, p += 3) {
                double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
                double d2 = dx * dx + dy * dy + dz * dz;
                out->d2 = d2;
                out->p = p;
                out += d2 < rho2;
            }
            sc->n = (size_t)(out - sc->a);
        }
    return 0;
}

/* Keeps the collected points closer than radius. */
static void keep_within(cand_list *sc, double radius)
{
    double r2 = radius * radius;
    size_t m = 0;
    for (size_t i = 0; i < sc->n; i++)
        if (sc->a[i].d2 < r2)
            sc->a[m++] = sc->a[i];
    sc->n = m;
}

/* The 13th smallest squared distance of the n >= 13 collected (which of
 * equal ones does not matter: only the value is used). */
static double kth_d2(cand *a, size_t n)
{
    select_smallest(a, n, WPD_SHARP_SPACING_K + 1);
    double d2 = a[0].d2;
    for (int i = 1; i <= WPD_SHARP_SPACING_K; i++)
        d2 = fmax(d2, a[i].d2);
    return d2;
}

/* The nearest points (up to WPD_KNN_MAX) closer than both cap and
 * WPD_SHARP_REACH spacings to q, in (d2, x, y, z) order, into pts, the
 * spacing from the WPD_SHARP_SPACING_K-th neighbour closer than cap.
 * Returns how many (0 when fewer than WPD_SHARP_SPACING_K + 1 lie within
 * cap). The spacing is read from one collection of radius at least
 * `first` (about a grid cell) when that holds enough points (the nearest
 * then lie within it), else from the growing boxes of capped_knn (rare).
 * The collection's radius is the last point's reach when larger: most
 * often it holds this one's reach too, and one collection is all (a second
 * when it does not and holds fewer than WPD_KNN_MAX points; when it holds
 * more, the nearest lie within it). */
static int neighbourhood(const wpd_grid *g, const double q[3], double cap, sharp_scratch *scr,
                         double *pts, double *spacing)
{
    cand_list *sc = &scr->ball;
    double first = fmin(cap, 1.2 * g->cell);
    double rho = fmin(cap, fmax(first, scr->hint));
    if (collect(g, q, rho, sc))
        return heap_neighbourhood(g, q, cap, pts, spacing);
    if (sc->n > WPD_SHARP_SPACING_K) {
        spacing_of(kth_d2(sc->a, sc->n), spacing); /* the 13 nearest lie within rho */
    } else {
        capped_best h;
        if (capped_knn(g, q, WPD_SHARP_SPACING_K + 1, cap, &h) <= WPD_SHARP_SPACING_K)
            return 0;
        spacing_of(h.d2[WPD_SHARP_SPACING_K], spacing);
    }
    double reach = fmin(WPD_SHARP_REACH * *spacing, cap);
    scr->hint = reach;
    if (reach > rho && sc->n < WPD_KNN_MAX && collect(g, q, reach, sc))
        return heap_neighbourhood(g, q, cap, pts, spacing);
    keep_within(sc, reach);
    size_t m = sc->n;
    if (m > WPD_KNN_MAX) {
        select_smallest(sc->a, m, WPD_KNN_MAX);
        m = WPD_KNN_MAX;
    }
    sort_cands(sc->a, m);
    for (size_t j = 0; j < m; j++)
        memcpy(pts + 3 * j, sc->a[j].p, 3 * sizeof(double));
    return (int)m;
}

/* ---- Verdicts, and the support of a crease point -------------------------
 *
 * Why support: the crease test alone labels single points here and there
 * (29 % of its crease points on NC Raleigh at the cap of a run to 100 K have
 * no other within 3 spacings), and the Poisson pass keeps such a point
 * almost always (nothing sharp near it: radius r/2), while it keeps one
 * point every r/2 along a real crease. On the oblique survey (300 K, seeds
 * 1-10) the labels `resample -n 1% --sharp` wrote were lone points in half
 * of the misses, and their precision was 0.76-0.87 against 0.81-0.87 over
 * every input point. With support (and the band, crease.h) 0.81-0.89,
 * recall 0.93-0.97. A point's support costs crease tests only around the
 * points the test puts on a crease, the nearest first. */

/* The crease test's verdicts kept per point (by source index), for the
 * support tests of the points around: not asked yet, off or on a crease. */
enum { RAW_UNKNOWN = 0, RAW_OFF = 1, RAW_ON = 2 };

/* The crease test's verdict on the point at q, and its spacing. */
static wpd_crease_verdict test_point(const wpd_grid *g, const double q[3], double cap,
                                     sharp_scratch *sc, double *spacing)
{
    double pts[3 * WPD_KNN_MAX];
    int got = neighbourhood(g, q, cap, sc, pts, spacing);
    return got <= 0 ? WPD_CREASE_SMALL_FACE : wpd_crease_test(pts, got, q, *spacing);
}

/* Threads may ask for the same point at once: each computes the same
 * verdict, so the byte only needs to be read and written whole. */
static uint8_t raw_get(const uint8_t *raw, uint32_t id)
{
    return raw ? __atomic_load_n(&raw[id], __ATOMIC_RELAXED) : RAW_UNKNOWN;
}

static void raw_put(uint8_t *raw, uint32_t id, wpd_crease_verdict v)
{
    if (raw)
        __atomic_store_n(&raw[id], v == WPD_CREASE_ON ? RAW_ON : RAW_OFF, __ATOMIC_RELAXED);
}

/* Whether the test puts grid point p (source index id) on a crease. */
static int raw_on(const wpd_grid *g, const double *p, uint32_t id, double cap,
                  sharp_scratch *sc, uint8_t *raw)
{
    uint8_t known = raw_get(raw, id);
    if (known != RAW_UNKNOWN)
        return known == RAW_ON;
    double spacing;
    wpd_crease_verdict v = test_point(g, p, cap, sc, &spacing);
    raw_put(raw, id, v);
    return v == WPD_CREASE_ON;
}

static uint32_t id_of(const wpd_grid *g, const double *p)
{
    return g->id[(size_t)(p - g->xyz) / 3];
}

/* Whether a grid point closer than radius to q, not at q's place, is on a
 * crease by the test: the nearest first (on a crease, the nearest points
 * mostly are on it too), or in the grid's order when the buffer cannot
 * grow (the same answer: whether one exists). */
static int supported(const wpd_grid *g, const double q[3], double radius, double cap,
                     sharp_scratch *sc, uint8_t *raw)
{
    cand_list *near = &sc->near;
    if (collect(g, q, radius, near) == 0) {
        sort_cands(near->a, near->n);
        for (size_t j = 0; j < near->n; j++)
            if (near->a[j].d2 > 0 && raw_on(g, near->a[j].p, id_of(g, near->a[j].p), cap, sc, raw))
                return 1;
        return 0;
    }
    int64_t lo[3], hi[3];
    if (!wpd_grid_box(g, q, radius, lo, hi))
        return 0;
    for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t a = lo[0]; a <= hi[0]; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
            for (uint32_t t = sb; t < se; t++) {
                const double *p = g->xyz + 3 * (size_t)t;
                double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
                double d2 = dx * dx + dy * dy + dz * dz;
                if (d2 > 0 && d2 < radius * radius && raw_on(g, p, g->id[t], cap, sc, raw))
                    return 1;
            }
        }
    return 0;
}

/* The verdict on the point at q (source index id): the crease test's, or
 * WPD_SHARP_ALONE for a point on a crease that no other crease point
 * within WPD_SHARP_SUPPORT of its spacings supports. Keeps the test's
 * verdict in raw (NULL: kept nowhere). */
static int verdict_of(const wpd_grid *g, const double q[3], uint32_t id, double cap,
                      sharp_scratch *sc, uint8_t *raw)
{
    double spacing;
    wpd_crease_verdict v = test_point(g, q, cap, sc, &spacing);
    raw_put(raw, id, v);
    if (v != WPD_CREASE_ON)
        return v;
    double radius = fmin(WPD_SHARP_SUPPORT * spacing, cap);
    return supported(g, q, radius, cap, sc, raw) ? WPD_CREASE_ON : WPD_SHARP_ALONE;
}

/* The label of the point at q: whether it is on a supported crease. A
 * point the test put off a crease (as another point's neighbour) needs no
 * second look. */
static int label_of(const wpd_grid *g, const double q[3], uint32_t id, double cap,
                    sharp_scratch *sc, uint8_t *raw)
{
    if (raw_get(raw, id) == RAW_OFF)
        return 0;
    return verdict_of(g, q, id, cap, sc, raw) == WPD_CREASE_ON;
}

/* A verdict for every source index of the grid's points (a grid over a
 * subset has indices up to the source's size); NULL when there is no
 * memory for it: the support tests then compute their verdicts again. */
static uint8_t *raw_verdicts(const wpd_grid *g)
{
    uint32_t most = 0;
    for (size_t s = 0; s < g->n; s++)
        most = g->id[s] > most ? g->id[s] : most;
    return calloc((size_t)most + 1, 1);
}

void wpd_detect_sharp_capped(const wpd_grid *surface, size_t begin, size_t end, double cap,
                             uint8_t *edge, int threads)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
    size_t slots = surface->n;
    uint8_t *raw = raw_verdicts(surface);
    /* Each label is computed on its own from its neighbourhood: any
     * schedule gives the same labels. */
#pragma omp parallel num_threads(threads)
    {
        sharp_scratch sc = {0};
#pragma omp for schedule(dynamic, 1024)
        for (size_t s = 0; s < slots; s++) {
            uint32_t id = surface->id[s];
            if (id < begin || id >= end)
                continue;
            edge[id] = (uint8_t)label_of(surface, surface->xyz + 3 * s, id, cap, &sc, raw);
        }
        scratch_free(&sc);
    }
    free(raw);
}

void wpd_sharp_verdicts(const wpd_grid *surface, double cap, uint8_t *verdict, int threads)
{
    if (threads <= 0)
        threads = omp_get_max_threads();
    size_t slots = surface->n;
    uint8_t *raw = raw_verdicts(surface);
#pragma omp parallel num_threads(threads)
    {
        sharp_scratch sc = {0};
#pragma omp for schedule(dynamic, 1024)
        for (size_t s = 0; s < slots; s++) {
            uint32_t id = surface->id[s];
            verdict[id] = (uint8_t)verdict_of(surface, surface->xyz + 3 * s, id, cap, &sc, raw);
        }
        scratch_free(&sc);
    }
    free(raw);
}

/* ---- Labels on demand ---------------------------------------------------- */

struct wpd_sharp_labeller {
    const wpd_grid *g;
    const double *xyz;
    double cap;
    uint8_t *edge;
    uint8_t *raw; /* the crease test's verdicts (RAW_*), by source index */
    int callers;
    sharp_scratch *scratch; /* [callers] */
    uint64_t *count;        /* [callers], labels each computed */
};

wpd_sharp_labeller *wpd_sharp_labeller_new(const wpd_grid *surface, const double *xyz, double cap,
                                           uint8_t *edge, int callers)
{
    wpd_sharp_labeller *l = calloc(1, sizeof *l);
    if (!l)
        return NULL;
    *l = (wpd_sharp_labeller){surface, xyz, cap, edge, NULL, callers > 1 ? callers : 1, NULL, NULL};
    l->raw = raw_verdicts(surface);
    l->scratch = calloc((size_t)l->callers, sizeof *l->scratch);
    l->count = calloc((size_t)l->callers, sizeof *l->count);
    if (!l->scratch || !l->count) { /* without l->raw, verdicts are computed again */
        wpd_sharp_labeller_free(l);
        return NULL;
    }
    return l;
}

int wpd_sharp_label(void *ctx, uint32_t point)
{
    wpd_sharp_labeller *l = ctx;
    int k = l->callers > 1 ? omp_get_thread_num() : 0;
    sharp_scratch none = {0}, *sc = k < l->callers ? &l->scratch[k] : &none;
    int edge = label_of(l->g, l->xyz + 3 * (size_t)point, point, l->cap, sc, l->raw);
    if (sc == &none)
        scratch_free(&none);
    else
        l->count[k]++;
    l->edge[point] = (uint8_t)edge;
    return edge;
}

uint64_t wpd_sharp_labeller_count(const wpd_sharp_labeller *l)
{
    uint64_t n = 0;
    for (int k = 0; k < l->callers; k++)
        n += l->count[k];
    return n;
}

void wpd_sharp_labeller_free(wpd_sharp_labeller *l)
{
    if (!l)
        return;
    for (int k = 0; l->scratch && k < l->callers; k++)
        scratch_free(&l->scratch[k]);
    free(l->scratch);
    free(l->raw);
    free(l->count);
    free(l);
}
