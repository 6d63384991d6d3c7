/* smooth_cover.c - the coverage limit on smoothing moves (smooth_guard.h):
 * which sample keeps which input point, and how far a move may go. */
#include "method/smooth_guard.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "common/hugepage.h"
#include "core/knn.h"


/* Owner of a point when there is no sample at all (sample indices stay
 * below it: a block holds fewer than 2^31 samples). */
#define NO_OWNER 0x7fffffffu

/* Nearest sample of one input point x (ties to the lower index, as wpd_knn
 * orders them) into *owner and B(x) into *bound, given d2/id, its best
 * candidate so far (beyond tau: ask the grid). B is stored as a float
 * rounded up (the factor exceeds float rounding), so the point stays within
 * its bound of where its sample starts. */
static void set_owner(const wpd_grid *samples, const double x[3], double tau, double d2,
                      uint32_t id, uint32_t *owner, float *bound)
{
    double b = tau;
    if (d2 > tau * tau) {
        /* The nearest may lie outside the candidates, but no farther than
         * the best of them: one box of that size settles it. */
        double hint = isinf(d2) ? 2 * tau : sqrt(d2) * (1 + 1e-9);
        if (wpd_knn(samples, x, 1, WPD_NO_SELF, INFINITY, hint, &id, &d2) < 1) {
            *owner = NO_OWNER; /* no sample at all */
            *bound = INFINITY;
            return;
        }
        b = d2 > tau * tau ? sqrt(d2) : tau;
    }
    *owner = id;
    *bound = (float)(b * (1 + 0x1p-21));
}

enum { GROUP_CANDIDATES = 256, GROUP_POINTS = 128, BLOCK_POINTS = 4096 };

/* Candidates for a group of input points inside the box [lo, hi]: the
 * sample slots within tau of the box. Returns how many, or -1 if more than
 * GROUP_CANDIDATES. */
static int group_candidates(const wpd_grid *samples, const double lo[3], const double hi[3],
                            double tau, uint32_t *cand)
{
    double c[3], half = 0;
    for (int a = 0; a < 3; a++) {
        c[a] = 0.5 * (lo[a] + hi[a]);
        half = fmax(half, 0.5 * (hi[a] - lo[a]));
    }
    int nc = 0;
    int64_t blo[3], bhi[3];
    if (!wpd_grid_box(samples, c, half + tau, blo, bhi))
        return 0;
    for (int64_t q = blo[1]; q <= bhi[1]; q++)
        for (int64_t p = blo[0]; p <= bhi[0]; p++) {
            uint32_t sb, se;
            wpd_grid_column_slots(samples, p, q, blo[2], bhi[2], &sb, &se);
            if (nc + (int)(se - sb) > GROUP_CANDIDATES)
                return -1;
            for (uint32_t t = sb; t < se; t++)
                cand[nc++] = t;
        }
    return nc;
}

/* A group's candidates side by side, one array per coordinate, padded to
 * whole lane groups with samples at infinity (the ids as doubles, exact:
 * the lanes compare them with the distances). */
enum { OWNER_LANES = 4 };
typedef struct group_cands {
    int n;  /* candidates, then padding up to a multiple of OWNER_LANES */
    double x[GROUP_CANDIDATES + OWNER_LANES], y[GROUP_CANDIDATES + OWNER_LANES],
        z[GROUP_CANDIDATES + OWNER_LANES], id[GROUP_CANDIDATES + OWNER_LANES];
} group_cands;

/* The candidate nearest to x by (squared distance, index) into *d2 and
 * *id: INFINITY and UINT32_MAX without one. Each lane keeps its own best
 * and the lanes are merged at the end, all without branches: the
 * candidates come in no useful order, and a compare-and-branch loop
 * mispredicted often. */
static void nearest_of_group(const group_cands *c, const double *x, double *d2, uint32_t *id)
{
    double bd[OWNER_LANES], bi[OWNER_LANES];
    for (int k = 0; k < OWNER_LANES; k++)
        bd[k] = INFINITY, bi[k] = (double)UINT32_MAX;
    for (int j = 0; j < c->n; j += OWNER_LANES) {
#pragma omp simd
        for (int k = 0; k < OWNER_LANES; k++) {
            double dx = c->x[j + k] - x[0], dy = c->y[j + k] - x[1], dz = c->z[j + k] - x[2];
            double d = dx * dx + dy * dy + dz * dz, i = c->id[j + k];
            int take = (d < bd[k]) | ((d == bd[k]) & (i < bi[k]));
            bd[k] = take ? d : bd[k];
            bi[k] = take ? i : bi[k];
        }
    }
    for (int k = 1; k < OWNER_LANES; k++)
        if (bd[k] < bd[0] || (bd[k] == bd[0] && bi[k] < bi[0]))
            bd[0] = bd[k], bi[0] = bi[k];
    *d2 = bd[0];
    *id = (uint32_t)bi[0];
}

/* A hint with the caller's numbers turned into order positions. */
typedef struct order_hint {
    const uint32_t *nearest; /* by slot: the caller's number, or WPD_COVER_NO_HINT */
    uint32_t *order;         /* the caller's number -> order position */
} order_hint;

/* The owner the hint gives the input point in slot s, or NO_OWNER: none. */
static uint32_t hinted_owner(const order_hint *hint, uint32_t s)
{
    uint32_t h = hint->nearest[s];
    return h == WPD_COVER_NO_HINT ? NO_OWNER : hint->order[h];
}

/* Owners and bounds of the input points in slots b..e-1, inside [lo, hi].
 * A point the hint names its nearest sample for takes that one (the
 * search would find it: it is strictly nearest); the others share their
 * candidates, gathered once and copied side by side (a point with no
 * candidate within tau, in a hole, asks the grid). Returns how many points
 * the hint settled. */
static size_t owners_of_group(const wpd_grid *samples, const double *start,
                            const wpd_grid *surface, const order_hint *hint, uint32_t b,
                            uint32_t e, const double lo[3], const double hi[3], double tau,
                            uint32_t *owner, float *bound)
{
    int left = hint ? 0 : (int)(e - b);
    size_t hinted = 0;
    for (uint32_t s = b; hint && s < e; s++) {
        const double *x = surface->xyz + 3 * (size_t)s;
        uint32_t id = hinted_owner(hint, s);
        if (id == NO_OWNER) {
            owner[s] = NO_OWNER;
            left++;
            continue;
        }
        const double *q = start + 3 * (size_t)id;
        double dx = q[0] - x[0], dy = q[1] - x[1], dz = q[2] - x[2];
        set_owner(samples, x, tau, dx * dx + dy * dy + dz * dz, id, owner + s, bound + s);
        hinted++;
    }
    if (left == 0)
        return hinted;
    uint32_t cand[GROUP_CANDIDATES];
    group_cands c;
    int nc = group_candidates(samples, lo, hi, tau, cand);
    for (c.n = 0; c.n < nc; c.n++) {
        const double *q = samples->xyz + 3 * (size_t)cand[c.n];
        c.x[c.n] = q[0], c.y[c.n] = q[1], c.z[c.n] = q[2];
        c.id[c.n] = samples->id[cand[c.n]];
    }
    for (; c.n % OWNER_LANES; c.n++)
        c.x[c.n] = c.y[c.n] = c.z[c.n] = INFINITY, c.id[c.n] = (double)UINT32_MAX;
    for (uint32_t s = b; s < e; s++) {
        if (hint && owner[s] != NO_OWNER)
            continue;
        const double *x = surface->xyz + 3 * (size_t)s;
        double best;
        uint32_t id;
        nearest_of_group(&c, x, &best, &id);
        set_owner(samples, x, tau, best, id, owner + s, bound + s);
    }
    return hinted;
}

/* Owners of the input points in slots b..e-1. The input is some 20 times
 * the samples, and this is most of the cost of the coverage: consecutive
 * slots (neighbours in space: the grid's order) are taken in groups that
 * fit in a box of tau/2 and share one candidate search. Returns how many
 * points the hint settled. */
static size_t owners_of_block(const wpd_grid *samples, const double *start,
                            const wpd_grid *surface, const order_hint *hint, uint32_t b,
                            uint32_t e, double tau, uint32_t *owner, float *bound)
{
    size_t hinted = 0;
    while (b < e) {
        const double *x = surface->xyz + 3 * (size_t)b;
        double lo[3] = {x[0], x[1], x[2]}, hi[3] = {x[0], x[1], x[2]};
        uint32_t t = b + 1;
        for (; t < e && t - b < GROUP_POINTS; t++) {
            const double *y = surface->xyz + 3 * (size_t)t;
            double l[3], h[3], extent = 0;
            for (int a = 0; a < 3; a++) { /* not fmin and fmax: calls, here */
                l[a] = y[a] < lo[a] ? y[a] : lo[a];
                h[a] = y[a] > hi[a] ? y[a] : hi[a];
                extent = h[a] - l[a] > extent ? h[a] - l[a] : extent;
            }
            if (extent > 0.5 * tau)
                break;
            memcpy(lo, l, sizeof lo);
            memcpy(hi, h, sizeof hi);
        }
        hinted +=
            owners_of_group(samples, start, surface, hint, b, t, lo, hi, tau, owner, bound);
        b = t;
    }
    return hinted;
}

int wpd_cover_init(wpd_cover *c, const wpd_grid *surface, const double *start, size_t n,
                   size_t nctx, double tau, const wpd_cover_hint *hint, int threads,
                   wpd_error *err)
{
    memset(c, 0, sizeof *c);
    c->n = n;
    c->surface = surface;
    size_t m = surface->n ? surface->n : 1;
    c->bound = wpd_malloc_large(m * sizeof *c->bound);
    c->owner = wpd_malloc_large(m * sizeof *c->owner);
    c->first = malloc((n + 2) * sizeof *c->first);
    wpd_grid g = {0};
    if (!c->bound || !c->owner || !c->first) {
        wpd_cover_free(c);
        return wpd_fail(err, WPD_E_MEMORY, "smooth: out of memory for %zu input points", m);
    }
    /* Cells of about the spacing: the nearest sample of a covered point is
     * within tau, so a point's candidates lie in a few cells. */
    if (wpd_grid_build(&g, start, NULL, n + nctx, tau > 0 ? tau : 1, threads, err)) {
        wpd_cover_free(c);
        return -1;
    }
    /* Without memory for the order, every point is searched for. */
    order_hint oh = {hint ? hint->nearest : NULL,
                     hint ? malloc((n ? n : 1) * sizeof *oh.order) : NULL};
    for (size_t o = 0; oh.order && o < n; o++)
        oh.order[hint->perm[o]] = (uint32_t)o;
    size_t hinted = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1) reduction(+ : hinted)
    for (size_t b = 0; b < surface->n; b += BLOCK_POINTS)
        hinted += owners_of_block(
            &g, start, surface, oh.order ? &oh : NULL, (uint32_t)b,
            (uint32_t)(surface->n - b < BLOCK_POINTS ? surface->n : b + BLOCK_POINTS), tau,
            c->owner, c->bound);
    c->hinted = hinted;
    free(oh.order);
    wpd_grid_free(&g);
    return 0;
}

void wpd_cover_free(wpd_cover *c)
{
    free(c->bound);
    free(c->owner);
    free(c->first);
    free(c->slot);
    memset(c, 0, sizeof *c);
}

/* 1 if a sample at p keeps input point x within its bound b: the one test
 * behind both the trust from a sample's ends and what its moves keep
 * (wpd_cover_holds), so the two judge a place alike. */
static int keeps(const double p[3], const double x[3], double b)
{
    double dx = p[0] - x[0], dy = p[1] - x[1], dz = p[2] - x[2];
    return !(dx * dx + dy * dy + dz * dz > b * b);
}

/* Whether sample i, at distance d from input point x (bound b), keeps x
 * within b wherever it goes this iteration: its cap says so, or each of
 * its possible ends does (where the guard has them). */
static int trusted(const wpd_cover *c, const wpd_spacing_guard *g, uint32_t i, double d,
                   const double x[3], double b)
{
    const wpd_step_ends *ends = g->ends;
    double cap = i < c->n ? g->cap[i] : 0; /* context samples stay */
    if (d + cap <= b)
        return 1;
    if (!ends || i >= c->n || d > b)
        return 0;
    const double *e = ends->xyz + 3 * (size_t)i * (size_t)ends->per;
    for (int j = 0; j < ends->count[i]; j++, e += 3)
        if (!keeps(e, x, b))
            return 0;
    return 1;
}

/* Whether input point s needs a keeper this iteration: its owner, or the
 * nearer of its two nearest samples, may be trusted to keep it within its
 * bound (trusted). Updates owner[s] (written only when it changes: most
 * points keep their owner, and a store to every point would dirty the
 * whole array each step). Returns the sample that must keep s, or
 * NO_OWNER when one is trusted to. */
static uint32_t look_after(wpd_cover *c, const wpd_spacing_guard *g, const double *pos,
                           size_t s)
{
    uint32_t i = c->owner[s];
    /* An owner that stays (cap 0, or a context sample) is trusted without
     * a look at the point: it lies within B(x) of x (the invariant). Most
     * samples stay in a step - in vegetation, and where no move pays -
     * and this spares reading the point and its owner. */
    if (i == NO_OWNER || i >= c->n || g->cap[i] <= 0)
        return NO_OWNER;
    const double *x = c->surface->xyz + 3 * s;
    double b = c->bound[s];
    const double *p = pos + 3 * (size_t)i;
    double dx = p[0] - x[0], dy = p[1] - x[1], dz = p[2] - x[2];
    if (trusted(c, g, i, sqrt(dx * dx + dy * dy + dz * dz), x, b))
        return NO_OWNER;
    uint32_t nb[2];
    double d2[2];
    int got = wpd_knn(g->grid, x, 2, WPD_NO_SELF, INFINITY, b, nb, d2);
    for (int j = 0; j < got; j++)
        if (trusted(c, g, nb[j], sqrt(d2[j]), x, b)) {
            c->owner[s] = nb[j];
            return NO_OWNER;
        }
    /* The nearest is within the bound (the invariant) and keeps it; a
     * context sample, which stays, only fails the test above by rounding. */
    if (got == 0)
        return NO_OWNER;
    c->owner[s] = nb[0];
    return nb[0] < c->n ? nb[0] : NO_OWNER;
}

/* One thread's points that need a keeper: (keeper, slot) pairs. */
typedef struct kept_list {
    uint32_t *pair;
    size_t n, cap;
    int failed;
} kept_list;

static void kept_add(kept_list *l, uint32_t keeper, uint32_t slot)
{
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 4096;
        uint32_t *grown = realloc(l->pair, 2 * cap * sizeof *grown);
        if (!grown) {
            l->failed = 1;
            return;
        }
        l->pair = grown;
        l->cap = cap;
    }
    l->pair[2 * l->n] = keeper;
    l->pair[2 * l->n + 1] = slot;
    l->n++;
}

/* The points each sample keeps, from the threads' lists, grouped by
 * keeper: a counting sort over the kept points alone, not over every
 * input point. Within a keeper the points come in no fixed order; what
 * reads them (wpd_cover_limit, wpd_cover_holds) takes a minimum or a
 * conjunction, so the order cannot change a result. */
static int group_kept(wpd_cover *c, const kept_list *lists, int nlists)
{
    size_t n = c->n, m = 0;
    memset(c->first, 0, (n + 2) * sizeof *c->first);
    for (int t = 0; t < nlists; t++) {
        m += lists[t].n;
        for (size_t k = 0; k < lists[t].n; k++)
            c->first[lists[t].pair[2 * k] + 2]++;
    }
    for (size_t o = 0; o < n; o++)
        c->first[o + 2] += c->first[o + 1];
    if (m > c->cap) {
        uint32_t *grown = realloc(c->slot, m * sizeof *grown);
        if (!grown)
            return -1;
        c->slot = grown;
        c->cap = m;
    }
    /* first[o + 1] runs as the fill cursor of o; it ends as o's end. */
    for (int t = 0; t < nlists; t++)
        for (size_t k = 0; k < lists[t].n; k++)
            c->slot[c->first[lists[t].pair[2 * k] + 1]++] = lists[t].pair[2 * k + 1];
    return 0;
}

int wpd_cover_update(wpd_cover *c, const wpd_spacing_guard *guard, const double *pos,
                     int threads, wpd_error *err)
{
    int team = threads > 0 ? threads : omp_get_max_threads();
    kept_list *lists = calloc((size_t)team, sizeof *lists);
    int nlists = 0, failed = !lists;
    if (lists) {
#pragma omp parallel num_threads(team)
        {
            /* Filled on the thread's own stack, stored once at the end:
             * neighbouring entries of lists[] share a cache line. */
            kept_list mine = {0};
#pragma omp single
            nlists = omp_get_num_threads();
#pragma omp for schedule(dynamic, 4096)
            for (size_t s = 0; s < c->surface->n; s++) {
                uint32_t keeper = look_after(c, guard, pos, s);
                if (keeper != NO_OWNER)
                    kept_add(&mine, keeper, (uint32_t)s);
            }
            lists[omp_get_thread_num()] = mine;
        }
        for (int t = 0; t < nlists; t++)
            failed |= lists[t].failed;
        if (!failed)
            failed = group_kept(c, lists, nlists) < 0;
        for (int t = 0; t < nlists; t++)
            free(lists[t].pair);
        free(lists);
    }
    if (failed)
        return wpd_fail(err, WPD_E_MEMORY, "smooth: out of memory for %zu input points",
                        c->surface->n);
    return 0;
}

double wpd_cover_limit(const wpd_cover *c, size_t o, const double p[3], const double m[3])
{
    double mm = m[0] * m[0] + m[1] * m[1] + m[2] * m[2], t = 1;
    if (mm <= 0)
        return 1;
    for (uint32_t a = c->first[o]; a < c->first[o + 1]; a++) {
        const double *x = c->surface->xyz + 3 * (size_t)c->slot[a];
        double w[3] = {p[0] - x[0], p[1] - x[1], p[2] - x[2]};
        double wm = w[0] * m[0] + w[1] * m[1] + w[2] * m[2];
        double b = c->bound[c->slot[a]];
        double excess = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] - b * b;
        if (excess > 0)
            return 0;
        /* |w + t m|^2 <= b^2 holds from t = 0 up to the larger root. */
        double root = (-wm + sqrt(wm * wm - mm * excess)) / mm;
        t = fmin(t, root);
    }
    return t > 0 ? t : 0;
}

int wpd_cover_holds(const wpd_cover *c, size_t o, const double p[3])
{
    for (uint32_t a = c->first[o]; a < c->first[o + 1]; a++)
        if (!keeps(p, c->surface->xyz + 3 * (size_t)c->slot[a], c->bound[c->slot[a]]))
            return 0;
    return 1;
}
