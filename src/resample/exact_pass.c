/* exact_pass.c - the exact count through tiles (exact.h): sweeps of
 * coverage-aware elimination until n samples are left, each tile's samples
 * staying in its tile. */
#include "resample/exact.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/select.h"
#include "core/sort.h"
#include "wpd/eliminate.h"

static uint64_t bits_of(double v)
{
    uint64_t b;
    memcpy(&b, &v, sizeof b);
    return b;
}

static double double_of(uint64_t b)
{
    double v;
    memcpy(&v, &b, sizeof v);
    return v;
}

static int half_of(const wpd_tile_samples *s, size_t i)
{
    return s->edge && s->edge[i];
}

/* Sample i's cost as the sweep ranks it (eliminate.h). */
static double cost_of(const exact_tile *x, size_t i)
{
    return wpd_eliminate_cost_of(x->cost[i], x->half && x->half[i]);
}

/* ------------------------------------------------------------ step 1 */

/* The samples a tile's costs need: its own and every other tile's within
 * 2 R of its box, in global-index order (the order the one-block sweep
 * breaks ties in); at[i]: the place of own sample i. */
typedef struct cost_view {
    size_t n;
    double *xyz;
    uint8_t *half;     /* NULL without sharp labels */
    uint32_t *at;
} cost_view;

static void cost_view_free(cost_view *v)
{
    free(v->xyz), free(v->half), free(v->at);
    memset(v, 0, sizeof *v);
}

/* The other tiles' samples within dist of t's box into near[u]. */
static int near_samples(const wpd_run *run, int t, double dist, wpd_tile_samples *near,
                        size_t *total, wpd_error *err)
{
    const wpd_tile *tile = &run->plan.tiles[t];
    *total = 0;
    for (int u = 0; u < run->plan.ntiles; u++) {
        if (u == t || wpd_store_count(run, u) == 0 ||
            wpd_tile_gap(tile, &run->plan.tiles[u]) > dist)
            continue;
        if (wpd_store_near(run, t, u, dist, &near[u], err))
            return -1;
        *total += near[u].n;
    }
    return 0;
}

/* The view of n samples: own (run->store[t], held) and near[u] for u != t,
 * sorted by global index. Returns 0 or -1 (out of memory). */
static int cost_view_fill(const wpd_run *run, int t, const wpd_tile_samples *near, size_t n,
                          int labelled, cost_view *v)
{
    const wpd_tile_samples *own = &run->store[t];
    size_t m = n ? n : 1;
    uint64_t *key = malloc(2 * m * sizeof *key), *src = malloc(m * sizeof *src);
    uint32_t *order = malloc(2 * m * sizeof *order);
    v->xyz = malloc(3 * m * sizeof *v->xyz);
    v->half = labelled ? calloc(m, 1) : NULL;
    v->at = malloc((own->n ? own->n : 1) * sizeof *v->at);
    int rc = key && src && order && v->xyz && v->at && (v->half || !labelled) ? 0 : -1;
    if (rc == 0) {
        size_t k = 0;
        for (int u = 0; u < run->plan.ntiles; u++) {
            const wpd_tile_samples *s = u == t ? own : &near[u];
            for (size_t i = 0; i < s->n; i++) {
                key[k] = s->gid[i];
                src[k++] = (uint64_t)u << 32 | i;
            }
        }
        for (size_t i = 0; i < n; i++)
            order[i] = (uint32_t)i;
        wpd_radix_sort_u64(key, order, n, 64, key + m, order + m);
        for (size_t i = 0; i < n; i++) {
            int u = (int)(src[order[i]] >> 32);
            size_t j = (size_t)(src[order[i]] & 0xffffffffu);
            const wpd_tile_samples *s = u == t ? own : &near[u];
            memcpy(v->xyz + 3 * i, s->xyz + 3 * j, 3 * sizeof *v->xyz);
            if (v->half)
                v->half[i] = (uint8_t)half_of(s, j);
            if (u == t)
                v->at[j] = (uint32_t)i;
        }
        v->n = n;
    }
    free(key), free(src), free(order);
    return rc;
}

static int cost_view_build(const wpd_run *run, int t, double dist, int labelled, cost_view *v,
                           wpd_error *err)
{
    int ntiles = run->plan.ntiles;
    wpd_tile_samples *near = calloc((size_t)ntiles, sizeof *near);
    size_t others = 0;
    int rc = near ? near_samples(run, t, dist, near, &others, err)
                  : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (rc == 0 && cost_view_fill(run, t, near, run->store[t].n + others, labelled, v))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count in tile %d", t);
    for (int u = 0; near && u < ntiles; u++)
        wpd_samples_free(&near[u]);
    free(near);
    return rc;
}

/* Step 1 for tile t: its samples' costs and crowding distances. */
static int cost_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    exact_sweep *sw = arg;
    exact_tile *x = &sw->tile[t];
    if (x->n == 0)
        return 0;
    cost_view v = {0};
    wpd_eliminate e = {0};
    wpd_tile_data d;
    int rc = -1;
    if (wpd_store_load(run, t, err))
        return -1;
    const wpd_tile_samples *s = &run->store[t];
    if (cost_view_build(run, t, 2 * sw->reach, sw->labelled, &v, err) ||
        wpd_eliminate_init(&e, v.xyz, v.half, v.n, run->res->radius, sw->reach, threads, err) ||
        wpd_eliminate_begin(&e, err) || wpd_tiles_read(&run->tiles, t, &d, err))
        goto done;
    wpd_eliminate_add_points(&e, d.xyz, NULL, d.n, threads);
    wpd_tiles_release(&run->tiles, &d);
    for (size_t i = 0; i < s->n; i++) {
        x->cost[i] = e.cost[v.at[i]];
        x->nn[i] = wpd_eliminate_nearest(&e, v.at[i]);
        if (x->half)
            x->half[i] = (uint8_t)half_of(s, i);
    }
    rc = 0;
done:
    wpd_eliminate_free(&e);
    cost_view_free(&v);
    wpd_store_drop(run, t);
    return rc;
}

/* ------------------------------------------------------------ step 2 */

typedef enum { KEY_COST, KEY_NEAREST, KEY_TAKEN_RANK, KEY_TAKEN_GID } key_kind;

typedef struct key_set {
    const exact_sweep *sw;
    key_kind kind;
    uint64_t rank;     /* KEY_TAKEN_GID: the rank the gids share */
} key_set;

static void count_key(uint64_t k, uint64_t mask, uint64_t prefix, int shift, uint64_t *hist)
{
    if ((k & mask) == prefix)
        hist[(k >> shift) & 0xffff]++;
}

/* wpd_select_count_fn over the keys of a key_set. */
static void count_keys(void *arg, uint64_t mask, uint64_t prefix, int shift, uint64_t *hist)
{
    const key_set *ks = arg;
    const wpd_run *run = ks->sw->run;
    for (int t = 0; t < run->plan.ntiles; t++) {
        const exact_tile *x = &ks->sw->tile[t];
        if (ks->kind == KEY_COST)
            for (size_t i = 0; i < x->n; i++)
                count_key(bits_of(cost_of(x, i)), mask, prefix, shift, hist);
        else if (ks->kind == KEY_NEAREST)
            for (size_t i = 0; i < x->n; i++)
                count_key(bits_of(x->nn[i]), mask, prefix, shift, hist);
        else
            for (size_t c = 0; c < x->ncand; c++)
                if (x->state[c] == EXACT_TAKEN) {
                    if (ks->kind == KEY_TAKEN_RANK)
                        count_key(x->rank[c], mask, prefix, shift, hist);
                    else if (x->rank[c] == ks->rank)
                        count_key(x->cgid[c], mask, prefix, shift, hist);
                }
    }
}

static uint64_t select_key(const exact_sweep *sw, key_kind kind, uint64_t rank, uint64_t k,
                           uint64_t *below, uint64_t *hist)
{
    key_set ks = {sw, kind, rank};
    return wpd_select_kth(count_keys, &ks, k, below, hist);
}

/* Tile t's candidates (a wpd_tile_fn): its samples whose cost_of is at
 * most the bound tau, with their global indices, coordinates and ranks. */
static int pick_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    (void)threads;
    exact_sweep *sw = arg;
    exact_tile *x = &sw->tile[t];
    size_t m = 0;
    for (size_t i = 0; i < x->n; i++)
        m += bits_of(cost_of(x, i)) <= sw->tau;
    if (m == 0)
        return 0;
    x->cand = malloc(m * sizeof *x->cand);
    x->cgid = malloc(m * sizeof *x->cgid);
    x->cxyz = malloc(3 * m * sizeof *x->cxyz);
    x->rank = malloc(m * sizeof *x->rank);
    x->state = calloc(m, 1);
    x->next = calloc(m, 1);
    if (!x->cand || !x->cgid || !x->cxyz || !x->rank || !x->state || !x->next)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count in tile %d", t);
    if (wpd_store_load(run, t, err))
        return -1;
    const wpd_tile_samples *s = &run->store[t];
    for (size_t i = 0; i < x->n; i++) {
        double c = cost_of(x, i);
        if (bits_of(c) > sw->tau)
            continue;
        size_t k = x->ncand++;
        x->cand[k] = (uint32_t)i;
        x->cgid[k] = s->gid[i];
        memcpy(x->cxyz + 3 * k, s->xyz + 3 * i, 3 * sizeof *x->cxyz);
        x->rank[k] = bits_of(c * wpd_eliminate_crowd_factor(x->nn[i], sw->median));
    }
    x->undecided = x->ncand;
    wpd_store_drop(run, t);
    return 0;
}

/* Every tile's candidates, and the sweep's largest conflict distance. */
static int pick_candidates(exact_sweep *sw, wpd_error *err)
{
    wpd_run *run = sw->run;
    if (wpd_run_tiles_any_order(run, NULL, pick_tile, sw, err))
        return -1;
    double top = 0;
    for (int t = 0; t < run->plan.ntiles; t++) {
        const exact_tile *x = &sw->tile[t];
        for (size_t c = 0; c < x->ncand; c++)
            top = fmax(top, double_of(x->cost[x->cand[c]]));
    }
    sw->conflict = 2 * sqrt(top);
    return 0;
}

/* ------------------------------------------------------------ step 3 */

/* Rounds of wpd_exact_decide_tile until every candidate is decided. */
static int decide_all(exact_sweep *sw, wpd_error *err)
{
    wpd_run *run = sw->run;
    size_t left = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        left += sw->tile[t].undecided;
    while (left > 0) {
        for (int t = 0; t < run->plan.ntiles; t++)
            memcpy(sw->tile[t].next, sw->tile[t].state, sw->tile[t].ncand);
        if (wpd_run_tiles_any_order(run, NULL, wpd_exact_decide_tile, sw, err))
            return -1;
        size_t now = 0;
        for (int t = 0; t < run->plan.ntiles; t++) {
            exact_tile *x = &sw->tile[t];
            memcpy(x->state, x->next, x->ncand);
            x->undecided = 0;
            for (size_t c = 0; c < x->ncand; c++)
                x->undecided += x->state[c] == EXACT_UNDECIDED;
            now += x->undecided;
        }
        if (now >= left)
            return wpd_fail(err, WPD_E_USAGE, "exact count: %zu candidates still undecided "
                            "after a round (a bug)", now);
        left = now;
        run->res->exact_rounds++;
    }
    return 0;
}

/* ------------------------------------------------------------ step 4 */

/* The cut of a sweep: taken candidates up to (rank, gid) <= (rank, gid)
 * are deleted (all of them when all is set). */
typedef struct cut {
    exact_sweep *sw;
    int all;
    uint64_t rank, gid;
} cut;

/* Tile t's share of the cut (a wpd_tile_fn). */
static int delete_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    (void)threads;
    const cut *k = arg;
    exact_tile *x = &k->sw->tile[t];
    size_t gone = 0;
    uint8_t *del = x->next; /* reused: 1 deleted, per candidate */
    for (size_t c = 0; c < x->ncand; c++) {
        del[c] = x->state[c] == EXACT_TAKEN &&
                 (k->all || x->rank[c] < k->rank || (x->rank[c] == k->rank && x->cgid[c] <= k->gid));
        gone += del[c];
    }
    if (gone == 0)
        return 0;
    if (wpd_store_load(run, t, err))
        return -1;
    wpd_tile_samples *s = &run->store[t];
    size_t n = 0, c = 0;
    for (size_t i = 0; i < s->n; i++) {
        int skip = c < x->ncand && x->cand[c] == i ? del[c++] : 0;
        if (skip)
            continue;
        s->gid[n] = s->gid[i];
        memmove(s->xyz + 3 * n, s->xyz + 3 * i, 3 * sizeof *s->xyz);
        if (s->edge)
            s->edge[n] = s->edge[i];
        n++;
    }
    s->n = n;
    return wpd_store_save(run, t, err);
}

static void sweep_free(exact_sweep *sw)
{
    for (int t = 0; sw->tile && t < sw->run->plan.ntiles; t++) {
        exact_tile *x = &sw->tile[t];
        free(x->cost), free(x->nn), free(x->half), free(x->cand), free(x->cgid), free(x->cxyz);
        free(x->rank), free(x->state), free(x->next);
        memset(x, 0, sizeof *x);
    }
}

/* Step 1's arrays for every tile. */
static int sweep_alloc(exact_sweep *sw)
{
    const wpd_run *run = sw->run;
    for (int t = 0; t < run->plan.ntiles; t++) {
        exact_tile *x = &sw->tile[t];
        size_t n = x->n = wpd_store_count(run, t), m = n ? n : 1;
        x->cost = malloc(m * sizeof *x->cost);
        x->nn = malloc(m * sizeof *x->nn);
        x->half = sw->labelled ? malloc(m) : NULL;
        if (!x->cost || !x->nn || (sw->labelled && !x->half))
            return -1;
    }
    return 0;
}

/* One sweep from live samples towards the target. */
static int sweep(exact_sweep *sw, size_t live, size_t target, uint64_t *hist, wpd_error *err)
{
    wpd_run *run = sw->run;
    if (sweep_alloc(sw))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count");
    if (wpd_run_tiles_any_order(run, NULL, cost_tile, sw, err))
        return -1;
    size_t quota = live - target;
    size_t bound = quota + (quota < live / 20 ? quota : live / 20);
    sw->tau = select_key(sw, KEY_COST, 0, (bound < live ? bound : live) - 1, NULL, hist);
    sw->median = double_of(select_key(sw, KEY_NEAREST, 0, live / 2, NULL, hist));
    if (pick_candidates(sw, err) || decide_all(sw, err))
        return -1;
    uint64_t taken = 0, below = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        for (size_t c = 0; c < sw->tile[t].ncand; c++)
            taken += sw->tile[t].state[c] == EXACT_TAKEN;
    cut k = {sw, taken <= quota, 0, 0};
    if (!k.all) {
        k.rank = select_key(sw, KEY_TAKEN_RANK, 0, quota - 1, &below, hist);
        k.gid = select_key(sw, KEY_TAKEN_GID, k.rank, quota - 1 - below, NULL, hist);
    }
    return wpd_run_tiles_any_order(run, NULL, delete_tile, &k, err);
}

int wpd_exact_phase(wpd_run *run, wpd_error *err)
{
    size_t target = run->opt->target, live = wpd_run_store_count(run);
    exact_sweep sw = {.run = run, .tile = calloc((size_t)run->plan.ntiles, sizeof *sw.tile),
                      .reach = run->halo};
    uint64_t *hist = malloc(WPD_SELECT_BUCKETS * sizeof *hist);
    int rc = sw.tile && hist ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    sw.labelled = wpd_store_labelled(run);
    while (rc == 0 && live > target) {
        rc = sweep(&sw, live, target, hist, err);
        sweep_free(&sw);
        live = wpd_run_store_count(run);
        run->res->exact_sweeps++;
    }
    free(sw.tile);
    free(hist);
    return rc;
}
