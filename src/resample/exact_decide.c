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
 * pass's three-valued rule (resample/poisson.c) with a conflict distance per
 * pair.
 */
#include "resample/exact_internal.h"

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

/* A tile's candidates as a view reads them: its own (all of them) or
 * another tile's border, with the states of the round. */
typedef struct part {
    size_t n;
    const uint32_t *idx;      /* candidate index of each (NULL: 0..n-1) */
    const double *xyz, *cost;
    const uint64_t *gid, *rank;
    const uint8_t *state;     /* by candidate index */
    void *copy[6];            /* what to free */
} part;

static void part_free(part *p)
{
    for (int i = 0; i < 6; i++)
        free(p->copy[i]);
    memset(p, 0, sizeof *p);
}

/* Tile t's own candidates (held by the caller). */
static void own_part(const exact_tile *x, part *p)
{
    *p = (part){.n = x->ncand, .xyz = x->cxyz, .cost = x->ccost, .gid = x->cgid,
                .rank = x->rank, .state = x->state};
}

/* Tile u's border candidates and states, read-only. */
static int border_part(const exact_sweep *sw, int u, part *p, wpd_error *err)
{
    static const exact_field field[6] = {EF_BIDX, EF_BXYZ, EF_BCOST, EF_BGID, EF_BRANK,
                                         EF_STATE};
    const void **at[6] = {(const void **)&p->idx, (const void **)&p->xyz,
                          (const void **)&p->cost, (const void **)&p->gid,
                          (const void **)&p->rank, (const void **)&p->state};
    memset(p, 0, sizeof *p);
    p->n = sw->tile[u].nborder;
    for (int i = 0; i < 6; i++)
        if (wpd_exact_peek(sw, u, field[i], &p->copy[i], at[i], err)) {
            p->n = 0; /* nothing to read: the caller frees what was read */
            return -1;
        }
    return 0;
}

/* p's candidates within reach of tile t's box (all when own) into v, or
 * only counted when v->xyz is NULL. */
static size_t add_part(const exact_sweep *sw, int t, const part *p, int own, view *v)
{
    const wpd_tile *tile = &sw->run->plan.tiles[t];
    double reach = 2 * sw->conflict;
    size_t added = 0;
    for (size_t k = 0; k < p->n; k++) {
        const double *q = p->xyz + 3 * k;
        double d = own ? 0 : wpd_tile_distance(tile, q);
        if (d > reach)
            continue;
        added++;
        if (!v->xyz)
            continue;
        size_t i = v->n++, c = p->idx ? p->idx[k] : k;
        memcpy(v->xyz + 3 * i, q, 3 * sizeof *q);
        v->cost[i] = p->cost[k];
        v->gid[i] = p->gid[k];
        v->rank[i] = p->rank[k];
        v->state[i] = p->state[c];
        v->blind[i] = d > sw->conflict;
        v->own[i] = own ? (uint32_t)c : UINT32_MAX;
    }
    return added;
}

/* Every candidate within 2 D of tile t's box: its own (held) and the
 * borders of the tiles within 2 D. */
static int gather(const exact_sweep *sw, int t, view *v, wpd_error *err)
{
    const wpd_plan *plan = &sw->run->plan;
    double reach = 2 * sw->conflict;
    part *parts = calloc((size_t)plan->ntiles, sizeof *parts);
    if (!parts)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    int rc = 0;
    size_t cap = 0;
    view probe = {0};
    for (int u = 0; rc == 0 && u < plan->ntiles; u++) {
        if (u == t)
            own_part(&sw->tile[t], &parts[u]);
        else if (sw->tile[u].nborder && wpd_tile_gap(&plan->tiles[t], &plan->tiles[u]) <= reach)
            rc = border_part(sw, u, &parts[u], err);
        if (rc == 0)
            cap += add_part(sw, t, &parts[u], u == t, &probe);
    }
    if (rc == 0 && view_alloc(v, cap))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count in tile %d", t);
    for (int u = 0; rc == 0 && u < plan->ntiles; u++)
        add_part(sw, t, &parts[u], u == t, v);
    for (int u = 0; u < plan->ntiles; u++)
        part_free(&parts[u]);
    free(parts);
    return rc;
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
    if (wpd_exact_hold(sw, t, EF_CANDS | EF(EF_STATE), err))
        return -1;
    if (gather(sw, t, &v, err))
        goto done;
    if (!(order = malloc((v.n ? v.n : 1) * sizeof *order)) || priority_order(&v, order) ||
        permute(&v, order) || wpd_exact_alloc(sw, t, EF(EF_NEXT), err)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count in tile %d", t);
        goto done;
    }
    memcpy(x->next, x->state, x->ncand);
    double cell = sw->conflict > 0 ? sw->conflict : run->radius;
    if (wpd_grid_build(&g, v.xyz, NULL, v.n, cell, threads, err))
        goto done;
    for (size_t i = 0; i < v.n; i++)
        if (v.state[i] == EXACT_UNDECIDED)
            v.state[i] = decide(&v, &g, sw->conflict, i);
    for (size_t i = 0; i < v.n; i++)
        if (v.own[i] != UINT32_MAX && v.state[i] != UNKNOWN)
            x->next[v.own[i]] = v.state[i];
    rc = wpd_exact_keep(sw, t, EF(EF_NEXT), err);
done:
    wpd_exact_let_go(sw, t, EF_CANDS | EF(EF_STATE) | EF(EF_NEXT));
    wpd_grid_free(&g);
    free(order);
    view_free(&v);
    return rc;
}
