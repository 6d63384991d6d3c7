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

/* Other tiles' samples within dist of t's box: counted, or (keys != NULL)
 * appended at *n with their global indices as keys and (tile, index)
 * pairs in src. */
static size_t near_samples(const wpd_run *run, int t, double dist, uint64_t *keys,
                           uint64_t *src, size_t *n)
{
    const wpd_tile *tile = &run->plan.tiles[t];
    size_t count = 0;
    for (int u = 0; u < run->plan.ntiles; u++) {
        if (u == t || wpd_tile_gap(tile, &run->plan.tiles[u]) > dist)
            continue;
        const wpd_tile_samples *s = &run->store[u];
        for (size_t i = 0; i < s->n; i++)
            if (wpd_tile_distance(tile, s->xyz + 3 * i) <= dist) {
                count++;
                if (keys) {
                    keys[*n] = s->gid[i];
                    src[(*n)++] = (uint64_t)u << 32 | i;
                }
            }
    }
    return count;
}

static int cost_view_build(const wpd_run *run, int t, double dist, int labelled, cost_view *v)
{
    const wpd_tile_samples *own = &run->store[t];
    size_t others = near_samples(run, t, dist, NULL, NULL, NULL);
    size_t n = own->n + others, m = n ? n : 1;
    uint64_t *key = malloc(2 * m * sizeof *key), *src = malloc(m * sizeof *src);
    uint32_t *order = malloc(2 * m * sizeof *order);
    v->xyz = malloc(3 * m * sizeof *v->xyz);
    v->half = labelled ? calloc(m, 1) : NULL;
    v->at = malloc((own->n ? own->n : 1) * sizeof *v->at);
    int rc = key && src && order && v->xyz && v->at && (v->half || !labelled) ? 0 : -1;
    if (rc == 0) {
        size_t k = 0;
        for (size_t i = 0; i < own->n; i++) {
            key[k] = own->gid[i];
            src[k++] = (uint64_t)t << 32 | i;
        }
        near_samples(run, t, dist, key, src, &k);
        for (size_t i = 0; i < n; i++)
            order[i] = (uint32_t)i;
        wpd_radix_sort_u64(key, order, n, 64, key + m, order + m);
        for (size_t i = 0; i < n; i++) {
            uint64_t s = src[order[i]];
            int u = (int)(s >> 32);
            size_t j = (size_t)(s & 0xffffffffu);
            memcpy(v->xyz + 3 * i, run->store[u].xyz + 3 * j, 3 * sizeof *v->xyz);
            if (v->half)
                v->half[i] = (uint8_t)half_of(&run->store[u], j);
            if (u == t)
                v->at[j] = (uint32_t)i;
        }
        v->n = n;
    }
    free(key), free(src), free(order);
    return rc;
}

/* Step 1 for tile t: its samples' costs and crowding distances. */
static int cost_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    exact_sweep *sw = arg;
    const wpd_tile_samples *s = &run->store[t];
    exact_tile *x = &sw->tile[t];
    if (s->n == 0)
        return 0;
    cost_view v = {0};
    wpd_eliminate e = {0};
    wpd_tile_data d;
    int labelled = sw->labelled, rc = -1;
    if (cost_view_build(run, t, 2 * sw->reach, labelled, &v)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count in tile %d", t);
        goto done;
    }
    if (wpd_eliminate_init(&e, v.xyz, v.half, v.n, run->res->radius, sw->reach, threads, err) ||
        wpd_eliminate_begin(&e, err) || wpd_tiles_read(&run->tiles, t, &d, err))
        goto done;
    wpd_eliminate_add_points(&e, d.xyz, NULL, d.n, threads);
    wpd_tiles_release(&run->tiles, &d);
    for (size_t i = 0; i < s->n; i++) {
        x->cost[i] = e.cost[v.at[i]];
        x->nn[i] = wpd_eliminate_nearest(&e, v.at[i]);
    }
    rc = 0;
done:
    wpd_eliminate_free(&e);
    cost_view_free(&v);
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
        const wpd_tile_samples *s = &run->store[t];
        const exact_tile *x = &ks->sw->tile[t];
        if (ks->kind == KEY_COST)
            for (size_t i = 0; i < s->n; i++)
                count_key(bits_of(wpd_eliminate_cost_of(x->cost[i], half_of(s, i))), mask,
                          prefix, shift, hist);
        else if (ks->kind == KEY_NEAREST)
            for (size_t i = 0; i < s->n; i++)
                count_key(bits_of(x->nn[i]), mask, prefix, shift, hist);
        else
            for (size_t c = 0; c < x->ncand; c++)
                if (x->state[c] == EXACT_TAKEN) {
                    if (ks->kind == KEY_TAKEN_RANK)
                        count_key(x->rank[c], mask, prefix, shift, hist);
                    else if (x->rank[c] == ks->rank)
                        count_key(s->gid[x->cand[c]], mask, prefix, shift, hist);
                }
    }
}

static uint64_t select_key(const exact_sweep *sw, key_kind kind, uint64_t rank, uint64_t k,
                           uint64_t *below, uint64_t *hist)
{
    key_set ks = {sw, kind, rank};
    return wpd_select_kth(count_keys, &ks, k, below, hist);
}

/* The candidates: samples whose cost_of is at most the bound tau, with
 * their ranks; and the sweep's largest conflict distance. */
static int pick_candidates(exact_sweep *sw, uint64_t tau, double median)
{
    wpd_run *run = sw->run;
    double top = 0;
    for (int t = 0; t < run->plan.ntiles; t++) {
        const wpd_tile_samples *s = &run->store[t];
        exact_tile *x = &sw->tile[t];
        size_t m = 0;
        for (size_t i = 0; i < s->n; i++)
            m += bits_of(wpd_eliminate_cost_of(x->cost[i], half_of(s, i))) <= tau;
        size_t cap = m ? m : 1;
        x->cand = malloc(cap * sizeof *x->cand);
        x->rank = malloc(cap * sizeof *x->rank);
        x->state = calloc(cap, 1);
        x->next = calloc(cap, 1);
        if (!x->cand || !x->rank || !x->state || !x->next)
            return -1;
        for (size_t i = 0; i < s->n; i++) {
            double c = wpd_eliminate_cost_of(x->cost[i], half_of(s, i));
            if (bits_of(c) > tau)
                continue;
            x->cand[x->ncand] = (uint32_t)i;
            x->rank[x->ncand++] = bits_of(c * wpd_eliminate_crowd_factor(x->nn[i], median));
            top = fmax(top, double_of(x->cost[i]));
        }
        x->undecided = x->ncand;
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

/* Deletes the taken candidates up to (rank, gid) <= (cut_rank, cut_gid)
 * (all of them when all is set) from every tile's samples. */
static void delete_taken(exact_sweep *sw, int all, uint64_t cut_rank, uint64_t cut_gid)
{
    wpd_run *run = sw->run;
    for (int t = 0; t < run->plan.ntiles; t++) {
        wpd_tile_samples *s = &run->store[t];
        exact_tile *x = &sw->tile[t];
        uint8_t *gone = x->state; /* reused: 1 deleted, per candidate */
        for (size_t c = 0; c < x->ncand; c++) {
            uint64_t g = s->gid[x->cand[c]];
            gone[c] = x->state[c] == EXACT_TAKEN &&
                      (all || x->rank[c] < cut_rank || (x->rank[c] == cut_rank && g <= cut_gid));
        }
        size_t k = 0, c = 0;
        for (size_t i = 0; i < s->n; i++) {
            int del = c < x->ncand && x->cand[c] == i ? gone[c++] : 0;
            if (del)
                continue;
            s->gid[k] = s->gid[i];
            memmove(s->xyz + 3 * k, s->xyz + 3 * i, 3 * sizeof *s->xyz);
            if (s->edge)
                s->edge[k] = s->edge[i];
            k++;
        }
        s->n = k;
    }
}

static void sweep_free(exact_sweep *sw)
{
    for (int t = 0; sw->tile && t < sw->run->plan.ntiles; t++) {
        exact_tile *x = &sw->tile[t];
        free(x->cost), free(x->nn), free(x->cand), free(x->rank), free(x->state), free(x->next);
        memset(x, 0, sizeof *x);
    }
}

/* One sweep from live samples towards the target. */
static int sweep(exact_sweep *sw, size_t live, size_t target, uint64_t *hist, wpd_error *err)
{
    wpd_run *run = sw->run;
    for (int t = 0; t < run->plan.ntiles; t++) {
        size_t n = run->store[t].n ? run->store[t].n : 1;
        if (!(sw->tile[t].cost = malloc(n * sizeof(uint64_t))) ||
            !(sw->tile[t].nn = malloc(n * sizeof(double))))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count");
    }
    if (wpd_run_tiles_any_order(run, NULL, cost_tile, sw, err))
        return -1;
    size_t quota = live - target;
    size_t bound = quota + (quota < live / 20 ? quota : live / 20);
    uint64_t tau = select_key(sw, KEY_COST, 0, (bound < live ? bound : live) - 1, NULL, hist);
    double median = double_of(select_key(sw, KEY_NEAREST, 0, live / 2, NULL, hist));
    if (pick_candidates(sw, tau, median))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count");
    if (decide_all(sw, err))
        return -1;
    uint64_t taken = 0, below = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        for (size_t c = 0; c < sw->tile[t].ncand; c++)
            taken += sw->tile[t].state[c] == EXACT_TAKEN;
    if (taken <= quota) {
        delete_taken(sw, 1, 0, 0);
        return 0;
    }
    uint64_t rank = select_key(sw, KEY_TAKEN_RANK, 0, quota - 1, &below, hist);
    uint64_t gid = select_key(sw, KEY_TAKEN_GID, rank, quota - 1 - below, NULL, hist);
    delete_taken(sw, 0, rank, gid);
    return 0;
}

int wpd_exact_phase(wpd_run *run, wpd_error *err)
{
    size_t target = run->opt->target, live = wpd_run_store_count(run);
    exact_sweep sw = {run, calloc((size_t)run->plan.ntiles, sizeof *sw.tile), run->halo, 0, 0};
    uint64_t *hist = malloc(WPD_SELECT_BUCKETS * sizeof *hist);
    int rc = sw.tile && hist ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int t = 0; t < run->plan.ntiles; t++)
        sw.labelled |= run->store[t].edge != NULL;
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
