/* exact.c - the exact count through tiles (exact.h): sweeps of
 * coverage-aware elimination until n samples are left, each tile's samples
 * staying in its tile. */
#include "resample/exact.h"
#include "resample/exact_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/bits.h"
#include "core/select.h"
#include "core/sort.h"
#include "spill/blobs.h"
#include "method/eliminate.h"
#include "method/smooth.h"
#include "resample/sample_store.h"
#include "resample/ranks.h"
#include "resample/fixed.h"
#include "resample/hints.h"

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
        for (int u = 0; u <= run->plan.ntiles; u++) { /* near[ntiles]: fixed.h */
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
    /* One more: earlier nights' samples (fixed.h), present but no tile's. */
    wpd_tile_samples *near = calloc((size_t)ntiles + 1, sizeof *near);
    size_t others = 0;
    int rc = near ? near_samples(run, t, dist, near, &others, err)
                  : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (rc == 0 && (rc = wpd_fixed_near(run, t, dist, &near[ntiles], err)) == 0)
        others += near[ntiles].n;
    if (rc == 0 && cost_view_fill(run, t, near, run->store[t].n + others, labelled, v))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count in tile %d", t);
    for (int u = 0; near && u <= ntiles; u++)
        wpd_samples_free(&near[u]);
    free(near);
    return rc;
}

/* Whether the exact count keeps each input point's nearest sample for
 * smoothing (run->nearest, by the surface grid's slots): one tile in
 * memory, with its surface grid over those points, that will be smoothed,
 * and no other samples than its own (earlier nights' samples would be
 * context there). */
static int keeps_nearest(const wpd_run *run, const wpd_tile_data *d)
{
    return run->res->in_memory && run->plan.ntiles == 1 && !run->owner && run->fixed.n == 0 &&
           wpd_params_smooths(run->p) && run->surface.n == d->n && d->n > 0 &&
           !wpd_hints_off_for_test();
}

/* Per view sample, its index in the tile's store (own samples, the first
 * own of them) or WPD_SMOOTH_NO_NEAREST (another tile's, an earlier
 * night's); NULL without memory. */
static uint32_t *store_numbers(const cost_view *v, size_t own)
{
    uint32_t *store_of = malloc((v->n ? v->n : 1) * sizeof *store_of);
    for (size_t i = 0; store_of && i < v->n; i++)
        store_of[i] = WPD_SMOOTH_NO_NEAREST;
    for (size_t i = 0; store_of && i < own; i++)
        store_of[v->at[i]] = (uint32_t)i;
    return store_of;
}

/* The nearest sample of each input point, from the view's numbering
 * (near) to the store's (run->nearest); without memory for it, none is
 * kept (smoothing then searches for them). */
static void keep_nearest(wpd_run *run, const cost_view *v, size_t own, uint32_t *near,
                         size_t npts)
{
    uint32_t *store_of = store_numbers(v, own);
    if (!store_of) {
        free(run->nearest);
        run->nearest = NULL;
        return;
    }
    for (size_t i = 0; i < npts; i++)
        near[i] = near[i] == WPD_ELIMINATE_NO_NEAREST ? WPD_SMOOTH_NO_NEAREST : store_of[near[i]];
    free(store_of);
}

/* Through tiles, the same for the tile's smoothing, kept in a file
 * (hints.h). Without memory for the numbering the hints the tile had
 * stay: renumbered with every deletion, they are still right. */
static int keep_hints(wpd_run *run, int t, const cost_view *v, size_t own,
                      const wpd_tile_data *d, const uint32_t *near, wpd_error *err)
{
    uint32_t *store_of = store_numbers(v, own);
    if (!store_of)
        return 0;
    wpd_hints_view hv = {v->xyz, store_of, own};
    int rc = wpd_hints_keep(run, t, d->xyz, near, d->n, &hv, err);
    free(store_of);
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
    if (wpd_exact_alloc(sw, t, EF_COSTS, err) || wpd_store_load(run, t, err))
        return -1;
    const wpd_tile_samples *s = &run->store[t];
    if (cost_view_build(run, t, 2 * sw->reach, sw->labelled, &v, err) ||
        wpd_eliminate_init(&e, v.xyz, v.half, v.n, run->radius, sw->reach, threads, err) ||
        wpd_eliminate_begin(&e, err) || wpd_tiles_read(&run->tiles, t, &d, err))
        goto done;
    /* Kept for smoothing, the nearest samples follow the surface grid's
     * slots, as the cover reads them; the points go in in that order (its
     * copy of them: the same costs, which take a maximum). */
    int keep = keeps_nearest(run, &d);
    if (keep && !run->nearest)
        run->nearest = malloc(d.n * sizeof *run->nearest);
    uint32_t *near = keep ? run->nearest
                     : run->hints ? malloc((d.n ? d.n : 1) * sizeof *near)
                                  : NULL;
    wpd_eliminate_add_points(&e, keep && near ? run->surface.xyz : d.xyz, NULL, d.n, threads,
                             near);
    int failed = 0;
    if (keep && near)
        keep_nearest(run, &v, s->n, near, d.n);
    else if (near)
        failed = keep_hints(run, t, &v, s->n, &d, near, err);
    if (!keep)
        free(near);
    wpd_tiles_release(&run->tiles, &d);
    if (failed)
        goto done;
    /* Every view sample's nearest at once (the batch asks no subset), about
     * 21 bytes a view sample for a moment: less than the tile's points just
     * let go, so the tile's peak stays where it was. */
    double *nn = malloc((v.n ? v.n : 1) * sizeof *nn);
    if (nn)
        wpd_eliminate_nearest_all(&e, nn);
    for (size_t i = 0; i < s->n; i++) {
        x->cost[i] = e.cost[v.at[i]];
        x->nn[i] = nn ? nn[v.at[i]] : wpd_eliminate_nearest(&e, v.at[i]);
        if (x->half)
            x->half[i] = (uint8_t)half_of(s, i);
    }
    free(nn);
    rc = wpd_exact_keep(sw, t, EF_COSTS, err);
done:
    if (rc)
        wpd_exact_let_go(sw, t, EF_COSTS);
    wpd_eliminate_free(&e);
    cost_view_free(&v);
    wpd_store_drop(run, t);
    return rc;
}

/* With the tiles shared between ranks (ranks.h), a tile's costs stay with its
 * owner: the selections sum the ranks' histograms (count_keys) and only the
 * owner picks the tile's candidates. The exchange after the costs carries
 * nothing but the agreement. */
static const wpd_tile_share nothing_share = {NULL, NULL, 1};

/* ------------------------------------------------------------ step 2 */

typedef enum { KEY_COST, KEY_NEAREST, KEY_TAKEN_RANK, KEY_TAKEN_GID } key_kind;

typedef struct key_set {
    exact_sweep *sw;
    key_kind kind;
    uint64_t rank;     /* KEY_TAKEN_GID: the rank the gids share */
    wpd_error *err;    /* the first failure to read a tile's fields */
    int failed;
    int agreed_failure; /* the ranks know of it: no more exchanges */
} key_set;

static void count_key(uint64_t k, uint64_t mask, uint64_t prefix, int shift, uint64_t *hist)
{
    if ((k & mask) == prefix)
        hist[(k >> shift) & 0xffff]++;
}

static const unsigned key_fields[] = {
    [KEY_COST] = EF(EF_COST) | EF(EF_HALF),
    [KEY_NEAREST] = EF(EF_NN),
    [KEY_TAKEN_RANK] = EF(EF_STATE) | EF(EF_RANK),
    [KEY_TAKEN_GID] = EF(EF_STATE) | EF(EF_RANK) | EF(EF_CGID),
};

/* One tile's keys of a key_set into hist. */
static void count_tile(const key_set *ks, const exact_tile *x, uint64_t mask, uint64_t prefix,
                       int shift, uint64_t *hist)
{
    if (ks->kind == KEY_COST)
        for (size_t i = 0; i < x->n; i++)
            count_key(wpd_double_bits(cost_of(x, i)), mask, prefix, shift, hist);
    else if (ks->kind == KEY_NEAREST)
        for (size_t i = 0; i < x->n; i++)
            count_key(wpd_double_bits(x->nn[i]), mask, prefix, shift, hist);
    else
        for (size_t c = 0; c < x->ncand; c++)
            if (x->state[c] == EXACT_TAKEN) {
                if (ks->kind == KEY_TAKEN_RANK)
                    count_key(x->rank[c], mask, prefix, shift, hist);
                else if (x->rank[c] == ks->rank)
                    count_key(x->cgid[c], mask, prefix, shift, hist);
            }
}

/* With the tiles shared between ranks, each rank counted its own tiles:
 * the histogram is the sum over the ranks (after agreeing on a failure to
 * read a tile's fields, which every rank then sees). */
static void sum_histogram_over_ranks(key_set *ks, uint64_t *hist)
{
    const wpd_run *run = ks->sw->run;
    if (!run->owner || ks->agreed_failure)
        return;
    wpd_error e = {0};
    if (ks->failed)
        e = *ks->err;
    if (wpd_par_agree(run->opt->par, &e) ||
        wpd_par_sum_u64(run->opt->par, hist, WPD_SELECT_BUCKETS, &e)) {
        ks->failed = ks->agreed_failure = 1;
        *ks->err = e;
    }
}

/* wpd_select_count_fn over the keys of a key_set, tile by tile (this
 * rank's tiles, summed over the ranks). */
static void count_keys(void *arg, uint64_t mask, uint64_t prefix, int shift, uint64_t *hist)
{
    key_set *ks = arg;
    int per_sample = ks->kind == KEY_COST || ks->kind == KEY_NEAREST;
    for (int t = 0; !ks->failed && t < ks->sw->run->plan.ntiles; t++) {
        const exact_tile *x = &ks->sw->tile[t];
        if ((per_sample ? x->n : x->ncand) == 0 || !wpd_run_owns(ks->sw->run, t))
            continue;
        if (wpd_exact_hold(ks->sw, t, key_fields[ks->kind], ks->err)) {
            ks->failed = 1;
            break;
        }
        count_tile(ks, x, mask, prefix, shift, hist);
        wpd_exact_let_go(ks->sw, t, key_fields[ks->kind]);
    }
    sum_histogram_over_ranks(ks, hist);
}

/* The key of rank k of a kind (0 with err set when a tile's fields could
 * not be read: *failed). */
static uint64_t select_key(exact_sweep *sw, key_kind kind, uint64_t rank, uint64_t k,
                           uint64_t *below, uint64_t *hist, int *failed, wpd_error *err)
{
    key_set ks = {sw, kind, rank, err, 0, 0};
    uint64_t key = wpd_select_kth(count_keys, &ks, k, below, hist);
    *failed |= ks.failed;
    return key;
}

/* Tile t's candidates (a wpd_tile_fn): its samples whose cost_of is at
 * most the bound tau, with their global indices, coordinates, raw costs
 * and ranks, and the border: those within 2.25 D of the box's faces,
 * all a neighbour's view can ask for (2 D; the quarter more keeps a
 * candidate at the very distance from being lost to rounding). */
static int pick_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    (void)threads;
    exact_sweep *sw = arg;
    exact_tile *x = &sw->tile[t];
    if (x->n == 0 || wpd_exact_hold(sw, t, EF_COSTS, err))
        return x->n == 0 ? 0 : -1;
    for (size_t i = 0; i < x->n; i++)
        x->ncand += wpd_double_bits(cost_of(x, i)) <= sw->tau;
    int rc = x->ncand == 0 ? 0 : -1;
    if (x->ncand && wpd_exact_alloc(sw, t, EF_CANDS | EF(EF_STATE) | EF(EF_NEXT), err) == 0 &&
        wpd_store_load(run, t, err) == 0) {
        const wpd_tile_samples *s = &run->store[t];
        size_t k = 0;
        for (size_t i = 0; i < x->n; i++) {
            double c = cost_of(x, i);
            if (wpd_double_bits(c) > sw->tau)
                continue;
            x->cand[k] = (uint32_t)i;
            x->cgid[k] = s->gid[i];
            memcpy(x->cxyz + 3 * k, s->xyz + 3 * i, 3 * sizeof *x->cxyz);
            x->ccost[k] = wpd_bits_double(x->cost[i]);
            x->rank[k++] = wpd_double_bits(c * wpd_eliminate_crowd_factor(x->nn[i], sw->median));
        }
        x->undecided = x->ncand;
        wpd_store_drop(run, t);
        rc = 0;
    }
    const wpd_tile *tile = &run->plan.tiles[t];
    double band = 2.25 * sw->conflict;
    for (size_t c = 0; rc == 0 && c < x->ncand; c++)
        x->nborder += wpd_tile_near_faces(tile, x->cxyz + 3 * c, band);
    if (rc == 0 && x->ncand && wpd_exact_alloc(sw, t, EF_BORDER, err) == 0) {
        size_t b = 0;
        for (size_t c = 0; c < x->ncand; c++)
            if (wpd_tile_near_faces(tile, x->cxyz + 3 * c, band)) {
                x->bidx[b] = (uint32_t)c;
                memcpy(x->bxyz + 3 * b, x->cxyz + 3 * c, 3 * sizeof *x->bxyz);
                x->bgid[b] = x->cgid[c], x->bcost[b] = x->ccost[c], x->brank[b++] = x->rank[c];
            }
        rc = wpd_exact_keep(sw, t, EF_CANDS | EF(EF_STATE) | EF_BORDER, err);
    } else if (rc == 0 && x->ncand) {
        rc = -1;
    }
    wpd_exact_let_go(sw, t, EF_COSTS | EF_CANDS | EF(EF_STATE) | EF(EF_NEXT) | EF_BORDER);
    return rc;
}

/* With the tiles shared between ranks: after the picks, each tile's counts,
 * border and states go to every rank (what another tile's decisions read:
 * exact_decide.c); after a round, its counts and states. */
#define PICKED (EF_BORDER | EF(EF_STATE))

static void pack_fields(exact_sweep *sw, int t, unsigned mask, wpd_bytes *out)
{
    exact_tile *x = &sw->tile[t];
    wpd_bytes_put_u64(out, x->ncand);
    wpd_bytes_put_u64(out, x->nborder);
    wpd_bytes_put_u64(out, x->undecided);
    wpd_bytes_put_u64(out, x->taken);
    wpd_error err = {0};
    if (x->ncand == 0)
        return;
    if (wpd_exact_hold(sw, t, mask, &err)) {
        out->failed = 1;
        out->error = err.code;
        return;
    }
    wpd_bytes_put(out, x->state, x->ncand);
    if (mask & EF_BORDER) {
        wpd_bytes_put(out, x->bidx, x->nborder * sizeof *x->bidx);
        wpd_bytes_put(out, x->bxyz, 3 * x->nborder * sizeof *x->bxyz);
        wpd_bytes_put(out, x->bgid, x->nborder * sizeof *x->bgid);
        wpd_bytes_put(out, x->bcost, x->nborder * sizeof *x->bcost);
        wpd_bytes_put(out, x->brank, x->nborder * sizeof *x->brank);
    }
    wpd_exact_let_go(sw, t, mask);
}

static int unpack_fields(exact_sweep *sw, int t, unsigned mask, wpd_bytes_in *in,
                         wpd_error *err)
{
    exact_tile *x = &sw->tile[t];
    uint64_t ncand = wpd_bytes_get_u64(in), nborder = wpd_bytes_get_u64(in);
    uint64_t undecided = wpd_bytes_get_u64(in), taken = wpd_bytes_get_u64(in);
    if (in->bad || ncand > x->n || nborder > ncand || undecided + taken > ncand ||
        ((mask & EF_BORDER) == 0 && (ncand != x->ncand || nborder != x->nborder)))
        return wpd_fail(err, WPD_E_IO, "tile %d's candidates from another rank do not add up",
                        t);
    x->ncand = ncand, x->nborder = nborder, x->undecided = undecided, x->taken = taken;
    if (ncand == 0)
        return 0;
    if (wpd_exact_alloc(sw, t, mask, err))
        return -1;
    if (wpd_bytes_get(in, x->state, x->ncand) ||
        ((mask & EF_BORDER) &&
         (wpd_bytes_get(in, x->bidx, x->nborder * sizeof *x->bidx) ||
          wpd_bytes_get(in, x->bxyz, 3 * x->nborder * sizeof *x->bxyz) ||
          wpd_bytes_get(in, x->bgid, x->nborder * sizeof *x->bgid) ||
          wpd_bytes_get(in, x->bcost, x->nborder * sizeof *x->bcost) ||
          wpd_bytes_get(in, x->brank, x->nborder * sizeof *x->brank)))) {
        wpd_exact_let_go(sw, t, mask);
        return wpd_fail(err, WPD_E_IO, "tile %d's candidates from another rank cut short", t);
    }
    for (size_t b = 0; (mask & EF_BORDER) && b < x->nborder; b++)
        if (x->bidx[b] >= x->ncand) {
            wpd_exact_let_go(sw, t, mask);
            return wpd_fail(err, WPD_E_IO, "tile %d's border from another rank: bad index", t);
        }
    return wpd_exact_keep(sw, t, mask, err);
}

static void pack_picks(const wpd_run *run, int t, void *arg, wpd_bytes *out)
{
    (void)run;
    pack_fields(arg, t, PICKED, out);
}

static int unpack_picks(wpd_run *run, int t, void *arg, wpd_bytes_in *in, wpd_error *err)
{
    (void)run;
    return unpack_fields(arg, t, PICKED, in, err);
}

static void pack_states(const wpd_run *run, int t, void *arg, wpd_bytes *out)
{
    (void)run;
    pack_fields(arg, t, EF(EF_STATE), out);
}

static int unpack_states(wpd_run *run, int t, void *arg, wpd_bytes_in *in, wpd_error *err)
{
    (void)run;
    return unpack_fields(arg, t, EF(EF_STATE), in, err);
}

static const wpd_tile_share picks_share = {pack_picks, unpack_picks, 1};
static const wpd_tile_share states_share = {pack_states, unpack_states, 1};

/* ------------------------------------------------------------ step 3 */

/* After a round, tile t's next becomes its state; returns the candidates
 * still undecided, or -1 with err set. */
static long advance(exact_sweep *sw, int t, wpd_error *err)
{
    exact_tile *x = &sw->tile[t];
    if (x->undecided == 0)
        return 0;
    if (wpd_exact_hold(sw, t, EF(EF_STATE) | EF(EF_NEXT), err))
        return -1;
    memcpy(x->state, x->next, x->ncand);
    x->undecided = x->taken = 0;
    for (size_t c = 0; c < x->ncand; c++) {
        x->undecided += x->state[c] == EXACT_UNDECIDED;
        x->taken += x->state[c] == EXACT_TAKEN;
    }
    wpd_exact_let_go(sw, t, EF(EF_NEXT));
    return wpd_exact_keep(sw, t, EF(EF_STATE), err) ? -1 : (long)x->undecided;
}

/* Rounds of wpd_exact_decide_tile until every candidate is decided. */
static int decide_all(exact_sweep *sw, wpd_error *err)
{
    wpd_run *run = sw->run;
    size_t left = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        left += sw->tile[t].undecided;
    while (left > 0) {
        /* Each rank decides and advances its own tiles (a round reads the
         * states of the round before, so all decide before any advances),
         * then the states go to every rank. */
        if (wpd_run_tiles_any_order_shared(run, NULL, wpd_exact_decide_tile, &nothing_share, sw,
                                           err))
            return -1;
        wpd_error_clear(err);
        for (int t = 0; err->code == WPD_OK && t < run->plan.ntiles; t++)
            if (wpd_run_owns(run, t))
                advance(sw, t, err);
        if (run->owner ? wpd_run_share_colour(run, -1, &states_share, sw, err)
                       : err->code != WPD_OK)
            return -1;
        size_t now = 0;
        for (int t = 0; t < run->plan.ntiles; t++)
            now += sw->tile[t].undecided;
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

#define CUT_FIELDS (EF(EF_STATE) | EF(EF_RANK) | EF(EF_CGID) | EF(EF_CAND))

/* The kept nearest samples after the store's samples moved (moved[i]: the
 * new index of sample i, or WPD_SMOOTH_NO_NEAREST: deleted, and so is a
 * point's nearest no longer); NULL moved (no memory): none kept. */
static void follow_store(wpd_run *run, const uint32_t *moved)
{
    if (!moved) {
        free(run->nearest);
        run->nearest = NULL;
        return;
    }
    for (size_t i = 0; i < run->surface.n; i++)
        if (run->nearest[i] != WPD_SMOOTH_NO_NEAREST)
            run->nearest[i] = moved[run->nearest[i]];
}

/* Tile t's samples but those the cut deletes (del: per candidate). */
static int delete_marked(wpd_run *run, int t, const exact_tile *x, const uint8_t *del,
                         wpd_error *err)
{
    if (wpd_store_load(run, t, err))
        return -1;
    wpd_tile_samples *s = &run->store[t];
    /* The input points' nearest samples follow the store (run->nearest,
     * or through tiles run->hints). */
    int follow = run->nearest || run->hints;
    uint32_t *moved = follow ? malloc((s->n ? s->n : 1) * sizeof *moved) : NULL;
    size_t n = 0, c = 0, before = s->n;
    for (size_t i = 0; i < s->n; i++) {
        int skip = c < x->ncand && x->cand[c] == i ? del[c++] : 0;
        if (moved)
            moved[i] = skip ? WPD_SMOOTH_NO_NEAREST : (uint32_t)n;
        if (skip)
            continue;
        s->gid[n] = s->gid[i];
        memmove(s->xyz + 3 * n, s->xyz + 3 * i, 3 * sizeof *s->xyz);
        if (s->edge)
            s->edge[n] = s->edge[i];
        n++;
    }
    s->n = n;
    if (run->nearest)
        follow_store(run, moved);
    int rc = !run->hints ? 0
             : moved     ? wpd_hints_renumber(run, t, moved, before, err)
                         : wpd_hints_forget(run, t, err); /* no memory to follow them */
    free(moved);
    return rc ? rc : wpd_store_save(run, t, err);
}

/* Tile t's share of the cut (a wpd_tile_fn). */
static int delete_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    (void)threads;
    const cut *k = arg;
    exact_tile *x = &k->sw->tile[t];
    if (x->ncand == 0)
        return 0;
    if (wpd_exact_hold(k->sw, t, CUT_FIELDS, err))
        return -1;
    uint8_t *del = malloc(x->ncand);
    size_t gone = 0;
    for (size_t c = 0; del && c < x->ncand; c++) {
        del[c] = x->state[c] == EXACT_TAKEN &&
                 (k->all || x->rank[c] < k->rank || (x->rank[c] == k->rank && x->cgid[c] <= k->gid));
        gone += del[c];
    }
    int rc = !del ? wpd_fail(err, WPD_E_MEMORY, "out of memory") : gone ? delete_marked(run, t, x, del, err) : 0;
    free(del);
    wpd_exact_let_go(k->sw, t, CUT_FIELDS);
    return rc;
}

/* One sweep from live samples towards the target. */
static int sweep(exact_sweep *sw, size_t live, size_t target, uint64_t *hist, wpd_error *err)
{
    wpd_run *run = sw->run;
    for (int t = 0; t < run->plan.ntiles; t++)
        sw->tile[t].n = wpd_store_count(run, t);
    if (wpd_run_tiles_any_order_shared(run, NULL, cost_tile, &nothing_share, sw, err))
        return -1;
    size_t quota = live - target;
    size_t bound = quota + (quota < live / 20 ? quota : live / 20);
    int failed = 0;
    sw->tau = select_key(sw, KEY_COST, 0, (bound < live ? bound : live) - 1, NULL, hist, &failed,
                         err);
    sw->median = wpd_bits_double(select_key(sw, KEY_NEAREST, 0, live / 2, NULL, hist, &failed, err));
    /* No two candidates conflict farther apart than twice the largest raw
     * cost's root: at most the bound's, and costs stop at the reach. */
    sw->conflict = 2 * sqrt(fmin(wpd_bits_double(sw->tau), sw->reach * sw->reach));
    if (failed || wpd_run_tiles_any_order_shared(run, NULL, pick_tile, &picks_share, sw, err) ||
        decide_all(sw, err))
        return -1;
    size_t taken = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        taken += sw->tile[t].taken;
    cut k = {sw, taken <= quota, 0, 0};
    if (!k.all) {
        uint64_t below = 0;
        k.rank = select_key(sw, KEY_TAKEN_RANK, 0, quota - 1, &below, hist, &failed, err);
        k.gid = select_key(sw, KEY_TAKEN_GID, k.rank, quota - 1 - below, NULL, hist, &failed, err);
        if (failed)
            return -1;
    }
    /* The samples the cut leaves, from each tile's owner to every rank. */
    static const wpd_tile_share samples_share = {NULL, NULL, 0};
    return wpd_run_tiles_any_order_shared(run, NULL, delete_tile, &samples_share, &k, err);
}

int wpd_exact_phase(wpd_run *run, wpd_error *err)
{
    size_t target = wpd_run_exact_target(run), live = wpd_run_store_count(run);
    if (live <= target)
        return 0;
    exact_sweep sw = {.run = run, .tile = calloc((size_t)run->plan.ntiles, sizeof *sw.tile),
                      .reach = run->halo, .labelled = wpd_store_labelled(run)};
    uint64_t *hist = malloc(WPD_SELECT_BUCKETS * sizeof *hist);
    int rc = sw.tile && hist ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (rc == 0 && run->files) {
        const char *dir = run->opt->tmpdir ? run->opt->tmpdir : ".";
        rc = wpd_blobs_open(dir, (size_t)run->plan.ntiles * EF_COUNT, &run->work_files,
                            &sw.blobs, err);
    }
    if (rc == 0 && wpd_hints_wanted(run) && !run->hints)
        rc = wpd_hints_open(run, err);
    while (rc == 0 && live > target) {
        rc = sweep(&sw, live, target, hist, err);
        wpd_exact_free_all(&sw);
        live = wpd_run_store_count(run);
        run->res->exact_sweeps++;
    }
    wpd_blobs_close(sw.blobs);
    free(sw.tile);
    free(hist);
    return rc;
}
