/* smooth_even.c - even-spacing steps: a sample moves onto the input point
 * near it that evens the local spacing of itself and its neighbours
 * (smooth_even.h). */
#include "method/smooth_even.h"

#include <math.h>
#include <omp.h>

#include "core/knn.h"

static double dist(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/* How a neighbour's spacing changes when one of its neighbours moves: with
 * that one left out, the sum of the (kk - 1) nearest of the rest and the
 * kk-th nearest distance (INFINITY if there are fewer); its spacing with
 * the moving sample at distance d is then (sum + min(d, next)) / kk. */
typedef struct spacing_without {
    double sum, next;
    int kk;
} spacing_without;

/* Puts distance d (of point id) into the ascending list low[0..*got) that
 * keeps the kk smallest seen (ids alongside, if given; equal distances in
 * arrival order). */
static inline void keep_smallest(double *low, uint32_t *ids, int *got, int kk, double d,
                                 uint32_t id)
{
    int at = *got < kk ? (*got)++ : kk;
    if (at == kk && d >= low[kk - 1])
        return;
    if (at == kk)
        at = kk - 1;
    for (; at > 0 && low[at - 1] > d; at--) {
        low[at] = low[at - 1];
        if (ids)
            ids[at] = ids[at - 1];
    }
    low[at] = d;
    if (ids)
        ids[at] = id;
}

/* The kk smallest of d[0..n) in ascending order into low[0..kk). */
static int smallest(const double *d, int n, int kk, double *low)
{
    int got = 0;
    for (int i = 0; i < n; i++)
        keep_smallest(low, NULL, &got, kk, d[i], 0);
    return got;
}

void wpd_even_spacings(const double *prev, size_t n, const uint32_t *nb, const uint8_t *cnt,
                       int k, double *spacing, wpd_even_nearest *nearest, int threads)
{
#pragma omp parallel for num_threads(threads) schedule(static, 1024)
    for (size_t o = 0; o < n; o++) {
        wpd_even_nearest *e = nearest + o;
        const uint32_t *l = nb + o * (size_t)k;
        int got = 0;
        for (int j = 0; j < cnt[o]; j++)
            keep_smallest(e->d, e->id, &got, WPD_EVEN_K + 1,
                          dist(prev + 3 * o, prev + 3 * (size_t)l[j]), l[j]);
        double sum = 0;
        int kk = got < WPD_EVEN_K ? got : WPD_EVEN_K;
        for (int j = 0; j < kk; j++)
            sum += e->d[j];
        for (int j = got; j < WPD_EVEN_K + 1; j++)
            e->id[j] = UINT32_MAX, e->d[j] = INFINITY;
        spacing[o] = kk ? sum / kk : 0;
    }
}

/* Neighbour s's spacing parts with sample o left out of its list, from
 * its nearest listed neighbours: o among the first WPD_EVEN_K or not,
 * the first WPD_EVEN_K others are among the first WPD_EVEN_K + 1. */
static spacing_without without(const wpd_even_view *v, size_t s, size_t o)
{
    const wpd_even_nearest *e = v->nearest + s;
    double low[WPD_EVEN_K + 1];
    int m = 0;
    for (int j = 0; j < WPD_EVEN_K + 1 && e->id[j] != UINT32_MAX; j++)
        if (e->id[j] != o)
            low[m++] = e->d[j];
    /* With o at its new place s has total + 1 listed neighbours, total
     * those other than o; only a list shorter than WPD_EVEN_K needs the
     * count. */
    int kk = WPD_EVEN_K;
    if (v->cnt[s] < WPD_EVEN_K) {
        int total = v->cnt[s];
        for (int j = 0; j < v->cnt[s]; j++)
            total -= v->nb[s * (size_t)v->k + j] == o;
        kk = total + 1 < WPD_EVEN_K ? total + 1 : WPD_EVEN_K;
    }
    spacing_without w = {0, INFINITY, kk};
    for (int j = 0; j < kk - 1 && j < m; j++)
        w.sum += low[j];
    if (m >= kk)
        w.next = low[kk - 1];
    return w;
}

/* The neighbours of the sample whose step is planned, gathered once: their
 * coordinates side by side, and for each neighbour that is a sample (not a
 * context sample) its place in the list and its spacing parts without the
 * sample. */
typedef struct step_view {
    int n;                                  /* listed neighbours */
    double x[WPD_KNN_MAX], y[WPD_KNN_MAX], z[WPD_KNN_MAX];
    int nw;                                 /* of them samples */
    uint8_t at[WPD_KNN_MAX];                /* their places in the list */
    spacing_without w[WPD_KNN_MAX];
    double t;                               /* the mean spacing to aim at */
} step_view;

/* The sum of squared deviations from t with the sample at q: its own
 * spacing among its listed neighbours, and each sample neighbour's.
 * Returns INFINITY where q is closer than floor to a listed neighbour, and
 * some value >= bound as soon as the partial sum reaches bound (its terms
 * are not negative, so the whole sum would too). */
static double energy(const step_view *sv, const double q[3], double floor, double bound)
{
    /* Squared distances first: the square root is taken of the nearest,
     * of the WPD_EVEN_K that make the spacing and of those the
     * neighbours' terms read (it is monotonic, so the same values). */
    double d2[WPD_KNN_MAX], low[WPD_EVEN_K], nearest = INFINITY;
    for (int j = 0; j < sv->n; j++) {
        double dx = q[0] - sv->x[j], dy = q[1] - sv->y[j], dz = q[2] - sv->z[j];
        d2[j] = dx * dx + dy * dy + dz * dz;
        nearest = d2[j] < nearest ? d2[j] : nearest;
    }
    if (sqrt(nearest) < floor)
        return INFINITY;
    int got = smallest(d2, sv->n, WPD_EVEN_K, low);
    double own = 0;
    for (int j = 0; j < got; j++)
        own += sqrt(low[j]);
    own = got ? own / got - sv->t : 0;
    double e = own * own;
    for (int s = 0; s < sv->nw && e < bound; s++) {
        const spacing_without *w = sv->w + s;
        double ms = (w->sum + fmin(sqrt(d2[sv->at[s]]), w->next)) / w->kk - sv->t;
        e += ms * ms;
    }
    return e;
}

/* Leaves out of cand[0..n) the input points exactly where the sample
 * stands (its own point, until it first moves) and returns how many are
 * left, in their order. Such a point can never be ranked: its sum is the
 * sum of staying, which a point must beat. At a large fraction of the
 * input the reach mostly holds nothing else (NC Raleigh to 50 %: 67 % of
 * the plans; to 10 %: 44 %), and those plans then need no sum at all. */
static int drop_where_it_stands(const wpd_grid *surface, const double p[3], uint32_t *cand,
                                int n)
{
    int kept = 0;
    for (int c = 0; c < n; c++) {
        const double *q = surface->xyz + 3 * (size_t)cand[c];
        if (!(q[0] == p[0] && q[1] == p[1] && q[2] == p[2]))
            cand[kept++] = cand[c];
    }
    return kept;
}

int wpd_even_candidates(const wpd_even_view *v, const wpd_grid *surface, size_t o,
                        const wpd_even_limits *lim, uint32_t slot[WPD_EVEN_TRIES])
{
    const double *p = v->prev + 3 * o;
    const uint32_t *l = v->nb + o * (size_t)v->k;
    uint32_t cand[WPD_EVEN_CANDIDATES];
    int found = wpd_knn_slots(surface, p, WPD_EVEN_CANDIDATES, WPD_NO_SELF, lim->reach,
                              lim->reach, cand, NULL);
    int got = drop_where_it_stands(surface, p, cand, found);
    if (got == 0)
        return 0;
    step_view sv;
    sv.n = v->cnt[o];
    sv.nw = 0;
    sv.t = v->spacing[o];
    for (int j = 0; j < sv.n; j++) {
        const double *x = v->prev + 3 * (size_t)l[j];
        sv.x[j] = x[0], sv.y[j] = x[1], sv.z[j] = x[2];
        if (l[j] < v->n) {
            sv.at[sv.nw] = (uint8_t)j;
            sv.w[sv.nw++] = without(v, l[j], o);
            sv.t += v->spacing[l[j]];
        }
    }
    sv.t /= sv.nw + 1;
    /* Staying is judged by the same sum, without the floor (the sample
     * may already be closer than it: the guards keep what is). */
    double stay = energy(&sv, p, 0, INFINITY) * (1 - 1e-12);
    double best[WPD_EVEN_TRIES];
    int kept = 0;
    for (int c = 0; c < got; c++) {
        const double *q = surface->xyz + 3 * (size_t)cand[c];
        if (dist(q, lim->start) > lim->wander)
            continue;
        /* A point must beat staying, and the worst kept once 4 are. */
        double bound = kept == WPD_EVEN_TRIES ? fmin(stay, best[kept - 1]) : stay;
        double e = energy(&sv, q, lim->floor, bound);
        if (!(e < bound))
            continue;
        /* Insertion after every equal sum: candidates come nearest first. */
        int at = kept < WPD_EVEN_TRIES ? kept++ : WPD_EVEN_TRIES - 1;
        for (; at > 0 && best[at - 1] > e; at--) {
            best[at] = best[at - 1];
            slot[at] = slot[at - 1];
        }
        best[at] = e;
        slot[at] = cand[c];
    }
    return kept;
}
