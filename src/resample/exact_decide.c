/* exact_decide.c - step 3 of a sweep of the exact count (exact.h): one
 * tile decides what it can of its own candidates.
 *
 * The sweep's greedy over all candidates in priority order (rank, global
 * index) takes a candidate unless a candidate taken before it lies within
 * twice the larger of their costs; no conflict reaches farther than D, the
 * sweep's largest such distance. A tile's view holds every candidate within
 * 2 D of its box, each with the state the tiles have settled so far (fixed
 * for the round). Candidates farther than D from the box are blind: the
 * view may miss candidates that conflict with them. In priority order, a
 * candidate not settled yet is
 *   UNKNOWN when it is blind, else
 *   SPARED  when a TAKEN candidate before it conflicts with it, else
 *   UNKNOWN when an UNKNOWN one before it conflicts with it, else
 *   TAKEN.
 * By induction on priority every TAKEN and SPARED is the greedy's own
 * decision: a candidate that is not blind sees every candidate that
 * conflicts with it. The UNKNOWN candidate of smallest priority over all
 * tiles is decided in the next round by its own tile, for which it is not
 * blind and all before it are settled: the rounds end. This is the Poisson
 * pass's three-valued rule (poisson_pass.c) with a conflict distance per
 * pair.
 */
#include "resample/exact.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/sort.h"

enum { UNKNOWN = 3 };

typedef struct view {
    size_t n, cap;
    double *xyz;       /* [3n] */
    double *cost;      /* [n] raw squared costs */
    uint64_t *gid;     /* [n] */
    uint64_t *rank;    /* [n] */
    uint8_t *state;    /* [n] */
    uint8_t *blind;    /* [n] */
    uint32_t *own;     /* [n] candidate index in the tile, or UINT32_MAX */
} view;

static void view_free(view *v)
{
    free(v->xyz), free(v->cost), free(v->gid), free(v->rank);
    free(v->state), free(v->blind), free(v->own);
    memset(v, 0, sizeof *v);
}

static int view_alloc(view *v, size_t cap)
{
    size_t m = cap ? cap : 1;
    v->cap = cap;
    v->xyz = malloc(3 * m * sizeof *v->xyz);
    v->cost = malloc(m * sizeof *v->cost);
    v->gid = malloc(m * sizeof *v->gid);
    v->rank = malloc(m * sizeof *v->rank);
    v->state = malloc(m);
    v->blind = malloc(m);
    v->own = malloc(m * sizeof *v->own);
    return v->xyz && v->cost && v->gid && v->rank && v->state && v->blind && v->own ? 0 : -1;
}

/* Tile u's candidates that lie within reach of tile t's box (all of them
 * for u == t) into v, or only counted when v->xyz is NULL. */
static size_t add_tile(const exact_sweep *sw, int t, int u, double reach, view *v)
{
    const wpd_tile *tile = &sw->run->plan.tiles[t];
    const exact_tile *x = &sw->tile[u];
    size_t added = 0;
    for (size_t c = 0; c < x->ncand; c++) {
        const double *p = x->cxyz + 3 * c;
        double d = u == t ? 0 : wpd_tile_distance(tile, p);
        if (d > reach)
            continue;
        added++;
        if (!v->xyz)
            continue;
        size_t i = v->n++;
        memcpy(v->xyz + 3 * i, p, 3 * sizeof *p);
        uint64_t bits = x->cost[x->cand[c]];
        memcpy(&v->cost[i], &bits, sizeof bits);
        v->gid[i] = x->cgid[c];
        v->rank[i] = x->rank[c];
        v->state[i] = x->state[c];
        v->blind[i] = d > sw->conflict;
        v->own[i] = u == t ? (uint32_t)c : UINT32_MAX;
    }
    return added;
}

/* Every candidate within 2 D of tile t's box. */
static int gather(const exact_sweep *sw, int t, view *v)
{
    const wpd_plan *plan = &sw->run->plan;
    double reach = 2 * sw->conflict;
    size_t cap = 0;
    view probe = {0};
    for (int u = 0; u < plan->ntiles; u++)
        if (u == t || wpd_tile_gap(&plan->tiles[t], &plan->tiles[u]) <= reach)
            cap += add_tile(sw, t, u, reach, &probe);
    if (view_alloc(v, cap))
        return -1;
    for (int u = 0; u < plan->ntiles; u++)
        if (u == t || wpd_tile_gap(&plan->tiles[t], &plan->tiles[u]) <= reach)
            add_tile(sw, t, u, reach, v);
    return 0;
}

/* The view's order of priority: by global index, then stably by rank. */
static int priority_order(const view *v, uint32_t *order)
{
    size_t n = v->n, m = n ? n : 1;
    uint64_t *key = malloc(2 * m * sizeof *key);
    uint32_t *tmp = malloc(m * sizeof *tmp);
    if (!key || !tmp) {
        free(key), free(tmp);
        return -1;
    }
    uint64_t top = 0;
    for (size_t i = 0; i < n; i++) {
        key[i] = v->gid[i], order[i] = (uint32_t)i;
        top |= key[i];
    }
    int bits = 1;
    while (bits < 64 && top >> bits)
        bits++;
    wpd_radix_sort_u64(key, order, n, bits, key + m, tmp);
    top = 0;
    for (size_t i = 0; i < n; i++) {
        key[i] = v->rank[order[i]];
        top |= key[i];
    }
    for (bits = 1; bits < 64 && top >> bits;)
        bits++;
    wpd_radix_sort_u64(key, order, n, bits, key + m, tmp);
    free(key), free(tmp);
    return 0;
}

/* The view's arrays permuted into order (new slot i = old order[i]). */
static int permute(view *v, const uint32_t *order)
{
    view p = {0};
    if (view_alloc(&p, v->n)) {
        view_free(&p);
        return -1;
    }
    for (size_t i = 0; i < v->n; i++) {
        size_t o = order[i];
        memcpy(p.xyz + 3 * i, v->xyz + 3 * o, 3 * sizeof *p.xyz);
        p.cost[i] = v->cost[o], p.gid[i] = v->gid[o], p.rank[i] = v->rank[o];
        p.state[i] = v->state[o], p.blind[i] = v->blind[o], p.own[i] = v->own[o];
    }
    p.n = v->n;
    view_free(v);
    *v = p;
    return 0;
}

/* The three-valued rule for slot i of the view (in priority order), all
 * slots before it decided. */
static uint8_t decide(const view *v, const wpd_grid *g, double conflict, size_t i)
{
    if (v->blind[i])
        return UNKNOWN;
    const double *q = v->xyz + 3 * i;
    int64_t lo[3], hi[3];
    int unknown = 0;
    if (!wpd_grid_box(g, q, conflict, lo, hi))
        return EXACT_TAKEN;
    for (int64_t b = lo[1]; b <= hi[1]; b++)
        for (int64_t a = lo[0]; a <= hi[0]; a++) {
            uint32_t sb, se;
            wpd_grid_column_slots(g, a, b, lo[2], hi[2], &sb, &se);
            for (uint32_t k = sb; k < se; k++) {
                uint32_t j = g->id[k];
                if (j >= i || v->state[j] == EXACT_SPARED)
                    continue;
                const double *p = g->xyz + 3 * (size_t)k;
                double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
                double reach2 = 4 * fmax(v->cost[i], v->cost[j]);
                if (dx * dx + dy * dy + dz * dz > reach2)
                    continue;
                if (v->state[j] == EXACT_TAKEN)
                    return EXACT_SPARED;
                unknown = 1;
            }
        }
    return unknown ? UNKNOWN : EXACT_TAKEN;
}

int wpd_exact_decide_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    exact_sweep *sw = arg;
    exact_tile *x = &sw->tile[t];
    if (x->undecided == 0)
        return 0;
    view v = {0};
    wpd_grid g = {0};
    uint32_t *order = NULL;
    int rc = -1;
    if (gather(sw, t, &v) || !(order = malloc((v.n ? v.n : 1) * sizeof *order)) ||
        priority_order(&v, order) || permute(&v, order)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count in tile %d", t);
        goto done;
    }
    double cell = sw->conflict > 0 ? sw->conflict : run->res->radius;
    if (wpd_grid_build(&g, v.xyz, NULL, v.n, cell, threads, err))
        goto done;
    for (size_t i = 0; i < v.n; i++)
        if (v.state[i] == EXACT_UNDECIDED)
            v.state[i] = decide(&v, &g, sw->conflict, i);
    for (size_t i = 0; i < v.n; i++)
        if (v.own[i] != UINT32_MAX && v.state[i] != UNKNOWN)
            x->next[v.own[i]] = v.state[i];
    rc = 0;
done:
    wpd_grid_free(&g);
    free(order);
    view_free(&v);
    return rc;
}
