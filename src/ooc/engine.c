/* engine.c - the out-of-core pipeline of engine.h. */
#include "ooc/engine.h"

#include <math.h>
#include <omp.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "core/grid.h"
#include "core/knn.h"
#include "core/sort.h"
#include "common/testhook.h"
#include "common/tmpdir.h"
#include "ooc/plan.h"
#include "ooc/scan.h"
#include "wpd/exact.h"
#include "wpd/ladder.h"
#include "wpd/poisson.h"
#include "wpd/radius.h"
#include "wpd/refine.h"
#include "wpd/smooth.h"

/* ------------------------------------------------------------------ budget */

enum {
    FIXED_BYTES = 48 << 20,               /* one thread's voxel ladder and batches,
                                             plan, runtime; more threads only where
                                             the rest of the budget holds their own
                                             (pass_threads) */
    SPILL_BUFFERS_MAX = 32 << 20,         /* all tiles' write buffers together */
    MIN_TILE_POINTS = 20000,
};

size_t wpd_engine_bytes_per_tile_point(uint32_t record_size)
{
    /* The tile's coordinates, index and halo flag (33), plus the larger of
     * what the two passes over it add: Poisson (candidate and kept lists 8,
     * grid copy and slot ids 28, priority, band, state and order 14, cells
     * ~8) or smoothing (surface grid ~40). Records are not in the tiles. */
    (void)record_size;
    return 128;
}

size_t wpd_engine_bytes_per_sample(uint32_t record_size)
{
    /* store 36, exact-count scratch ~70, result (index, xyz, record) */
    return 140 + record_size;
}

/* The first pass may overshoot n: budget samples for 1.3 n. */
static size_t samples_bytes(uint64_t target, uint32_t record_size)
{
    return (size_t)(1.3 * (double)target) * wpd_engine_bytes_per_sample(record_size);
}

size_t wpd_engine_min_budget(uint64_t target, uint32_t record_size)
{
    return FIXED_BYTES + SPILL_BUFFERS_MAX / 4 + samples_bytes(target, record_size) +
           (size_t)WPD_ENGINE_TILES_IN_FLIGHT * MIN_TILE_POINTS *
               wpd_engine_bytes_per_tile_point(record_size);
}

/* Threads a streaming pass may run: each beyond the first needs per_thread
 * bytes of its own (the first one's are in FIXED_BYTES), out of what the
 * budget leaves beside in_use bytes held during that pass. The passes'
 * results do not depend on it. */
static int pass_threads(size_t mem, int threads, size_t in_use, size_t per_thread)
{
    size_t used = FIXED_BYTES + in_use;
    return wpd_threads_within(threads, mem > used ? mem - used : 0, per_thread);
}

/* ------------------------------------------------------------------ state */

typedef struct tile_samples {
    size_t n;
    uint64_t *gid;            /* ascending */
    double *xyz;              /* frame coordinates */
} tile_samples;

typedef struct engine {
    const wpd_engine_options *opt;
    wpd_cloud *cloud;
    uint32_t record_size;
    int threads;
    wpd_scan scan;
    wpd_plan plan;
    wpd_spill *spill;
    tile_samples *store;      /* [ntiles] */
    wpd_engine_result *res;
} engine;

static void store_clear(engine *e)
{
    for (int t = 0; e->store && t < e->plan.ntiles; t++) {
        free(e->store[t].gid);
        free(e->store[t].xyz);
        memset(&e->store[t], 0, sizeof e->store[t]);
    }
}

static size_t store_count(const engine *e)
{
    size_t total = 0;
    for (int t = 0; t < e->plan.ntiles; t++)
        total += e->store[t].n;
    return total;
}

/* ------------------------------------------------------------------ tiling */

/* Whether p, inside t's box, is at least m from each of its faces. */
static int deep_inside(const wpd_tile *t, const double p[3], double m)
{
    for (int a = 0; a < 3; a++)
        if (p[a] - t->box_lo[a] < m || t->box_hi[a] - p[a] < m)
            return 0;
    return 1;
}

/* One batch's points grouped by destination tile. */
typedef struct routing {
    size_t cap, n;
    uint32_t *tile, *point;   /* [n] entries: destination, point in batch */
    uint8_t *halo;
    size_t *start, *fill;     /* [ntiles + 1] first entry of each tile's group */
    uint64_t *gid;            /* [n] the entries' columns, grouped by tile */
    double *xyz;
    uint8_t *hflag;
} routing;

static void routing_free(routing *r)
{
    free(r->tile); free(r->point); free(r->halo); free(r->start); free(r->fill);
    free(r->gid); free(r->xyz); free(r->hflag);
    memset(r, 0, sizeof *r);
}

/* Room for cap entries. Returns 0, or -1 when out of memory (r stays
 * valid for routing_free). */
static int routing_reserve(routing *r, size_t cap, int ntiles)
{
    if (cap <= r->cap)
        return 0;
    void *p[6] = {realloc(r->tile, cap * sizeof *r->tile),
                  realloc(r->point, cap * sizeof *r->point), realloc(r->halo, cap),
                  realloc(r->gid, cap * sizeof *r->gid),
                  realloc(r->xyz, 3 * cap * sizeof *r->xyz), realloc(r->hflag, cap)};
    /* Keep whatever was reallocated, so routing_free frees it. */
    if (p[0]) r->tile = p[0];
    if (p[1]) r->point = p[1];
    if (p[2]) r->halo = p[2];
    if (p[3]) r->gid = p[3];
    if (p[4]) r->xyz = p[4];
    if (p[5]) r->hflag = p[5];
    if (!r->start)
        r->start = malloc(((size_t)ntiles + 1) * sizeof *r->start);
    if (!r->fill)
        r->fill = malloc(((size_t)ntiles + 1) * sizeof *r->fill);
    for (int i = 0; i < 6; i++)
        if (!p[i])
            return -1;
    if (!r->start || !r->fill)
        return -1;
    r->cap = cap;
    return 0;
}

static int route_point(routing *r, uint32_t tile, uint32_t point, uint8_t halo)
{
    if (r->n == r->cap)
        return -1;
    r->tile[r->n] = tile;
    r->point[r->n] = point;
    r->halo[r->n] = halo;
    r->n++;
    return 0;
}

/* Destinations of every point of the batch (frame coordinates in fxyz). */
static int route_batch(const engine *e, const double *fxyz, size_t n, routing *r)
{
    r->n = 0;
    const wpd_plan *pl = &e->plan;
    double halo2 = pl->halo * pl->halo;
    for (size_t i = 0; i < n; i++) {
        const double *p = fxyz + 3 * i;
        int home = pl->cell_tile[wpd_scan_cell_of(&e->scan, p)];
        const wpd_tile *t = &pl->tiles[home];
        if (route_point(r, (uint32_t)home, (uint32_t)i, 0))
            return -1;
        if (deep_inside(t, p, pl->halo))
            continue;
        for (int j = 0; j < t->nadj; j++)
            if (wpd_tile_distance2(&pl->tiles[t->adj[j]], p) < halo2 &&
                route_point(r, (uint32_t)t->adj[j], (uint32_t)i, 1))
                return -1;
    }
    return 0;
}

/* Groups the entries by tile (a stable counting sort) and gathers their
 * global index, frame coordinates and halo flag in that order. */
static void group_by_tile(routing *r, int ntiles, const double *fxyz, uint64_t first_gid)
{
    memset(r->start, 0, ((size_t)ntiles + 1) * sizeof *r->start);
    for (size_t i = 0; i < r->n; i++)
        r->start[r->tile[i] + 1]++;
    for (int t = 0; t < ntiles; t++)
        r->start[t + 1] += r->start[t];
    memcpy(r->fill, r->start, (size_t)ntiles * sizeof *r->fill);
    for (size_t i = 0; i < r->n; i++) {
        size_t k = r->fill[r->tile[i]]++, p = r->point[i];
        r->gid[k] = first_gid + p;
        memcpy(r->xyz + 3 * k, fxyz + 3 * p, 3 * sizeof *r->xyz);
        r->hflag[k] = r->halo[i];
    }
}

/* Appends the grouped entries to their tiles' spill. */
static int append_groups(engine *e, const routing *r, wpd_error *err)
{
    for (int t = 0; t < e->plan.ntiles; t++) {
        size_t b = r->start[t], m = r->start[t + 1] - b;
        if (m && wpd_spill_append(e->spill, t, r->gid + b, r->xyz + 3 * b, r->hflag + b, NULL,
                                  m, err))
            return -1;
    }
    return 0;
}

/* The tile pass runs on every thread: each takes the next batch (reading
 * is serial, under a lock), converts and routes it on its own, then waits
 * for its turn to append: batches reach the spill in reading order, so
 * every tile holds its points in global-index order, whatever the threads.
 * Routing one batch overlaps reading and appending the others. */
typedef struct tiler {
    engine *e;
    pthread_mutex_t mu;
    pthread_cond_t turn;      /* next_append moved on */
    uint64_t next_read;       /* sequence number of the next batch read */
    uint64_t next_append;     /* sequence number whose turn it is to append */
    uint64_t next_gid;        /* global index of the next point read */
    int stop;                 /* end of input, or a failure */
    int failed;
    wpd_error err;            /* the first failure */
} tiler;

/* One thread's buffers. */
typedef struct tiler_lane {
    wpd_batch batch;
    double *fxyz;
    routing r;
} tiler_lane;

enum { TILE_BATCH = 65536 };

static int lane_init(tiler_lane *l, const engine *e)
{
    memset(l, 0, sizeof *l);
    l->fxyz = malloc(3 * TILE_BATCH * sizeof *l->fxyz);
    /* Halo copies: a point lands in at most a few tiles; grow on demand. */
    return l->fxyz && wpd_batch_init(&l->batch, TILE_BATCH, e->record_size) == 0 &&
                   routing_reserve(&l->r, 2 * TILE_BATCH, e->plan.ntiles) == 0
               ? 0
               : -1;
}

static void lane_free(tiler_lane *l)
{
    wpd_batch_free(&l->batch);
    routing_free(&l->r);
    free(l->fxyz);
}

static void tiler_fail(tiler *tl, const wpd_error *err)
{
    pthread_mutex_lock(&tl->mu);
    if (!tl->failed)
        tl->err = *err;
    tl->failed = tl->stop = 1;
    pthread_mutex_unlock(&tl->mu);
}

/* Reads the next batch into l; sets its sequence number and first global
 * index. Returns the points read, 0 at the end or after a failure. */
static long lane_read(tiler *tl, tiler_lane *l, uint64_t *seq, uint64_t *first_gid)
{
    long got = 0;
    wpd_error err = {0};
    pthread_mutex_lock(&tl->mu);
    if (!tl->stop) {
        got = wpd_cloud_read(tl->e->cloud, &l->batch, NULL, &err);
        *seq = tl->next_read++;
        *first_gid = tl->next_gid;
        if (got > 0)
            tl->next_gid += (uint64_t)got;
        else
            tl->stop = 1;
    }
    pthread_mutex_unlock(&tl->mu);
    if (got < 0) {
        tiler_fail(tl, &err);
        return 0;
    }
    return got;
}

/* Converts to frame coordinates, routes and groups the batch in l. */
static int lane_route(const engine *e, tiler_lane *l, uint64_t first_gid)
{
    const wpd_batch *b = &l->batch;
    for (size_t i = 0; i < b->n; i++)
        for (int a = 0; a < 3; a++)
            l->fxyz[3 * i + a] = b->xyz[3 * i + a] - e->scan.origin[a];
    while (route_batch(e, l->fxyz, b->n, &l->r))
        if (routing_reserve(&l->r, 2 * l->r.cap, e->plan.ntiles))
            return -1;
    group_by_tile(&l->r, e->plan.ntiles, l->fxyz, first_gid);
    return 0;
}

/* Appends the routed batch seq once every earlier batch is in. */
static void lane_append(tiler *tl, tiler_lane *l, uint64_t seq)
{
    engine *e = tl->e;
    pthread_mutex_lock(&tl->mu);
    while (tl->next_append != seq)
        pthread_cond_wait(&tl->turn, &tl->mu);
    int failed = tl->failed;
    pthread_mutex_unlock(&tl->mu);
    wpd_error err = {0};
    if (!failed && append_groups(e, &l->r, &err))
        tiler_fail(tl, &err);
    wpd_progress_add(e->opt->progress, l->batch.n);
    wpd_test_stall("tile");
    pthread_mutex_lock(&tl->mu);
    tl->next_append++;
    pthread_cond_broadcast(&tl->turn);
    pthread_mutex_unlock(&tl->mu);
}

static void tiler_lane_run(tiler *tl)
{
    tiler_lane l;
    if (lane_init(&l, tl->e)) {
        wpd_error err;
        wpd_fail(&err, WPD_E_MEMORY, "out of memory for tiling");
        tiler_fail(tl, &err);
        /* A lane that never reads takes no turn: nobody waits for it. */
        lane_free(&l);
        return;
    }
    uint64_t seq = 0, first_gid = 0;
    while (lane_read(tl, &l, &seq, &first_gid) > 0) {
        if (lane_route(tl->e, &l, first_gid)) {
            wpd_error err;
            wpd_fail(&err, WPD_E_MEMORY, "out of memory for tiling");
            tiler_fail(tl, &err);
        }
        lane_append(tl, &l, seq); /* takes its turn even after a failure */
    }
    lane_free(&l);
}

static int tile_pass(engine *e, wpd_error *err)
{
    tiler tl = {.e = e};
    if (wpd_cloud_rewind(e->cloud, err))
        return -1;
    pthread_mutex_init(&tl.mu, NULL);
    pthread_cond_init(&tl.turn, NULL);
    /* A lane: batch, frame coordinates and routing for twice its points. */
    size_t lane_bytes = (size_t)TILE_BATCH * (e->record_size + 48) + 2 * (size_t)TILE_BATCH * 42;
    int lanes = pass_threads(e->opt->mem_bytes, e->threads, SPILL_BUFFERS_MAX, lane_bytes);
#pragma omp parallel num_threads(lanes)
    tiler_lane_run(&tl);
    pthread_mutex_destroy(&tl.mu);
    pthread_cond_destroy(&tl.turn);
    if (tl.failed) {
        if (err)
            *err = tl.err;
        return -1;
    }
    return wpd_spill_finish(e->spill, err);
}

/* ------------------------------------------------------------------ Poisson passes */

/* Samples of t's neighbours (their store) within dist of t's box. */
static int gather_neighbour_samples(const engine *e, int t, double dist, double **out,
                                    size_t *n)
{
    const wpd_tile *tile = &e->plan.tiles[t];
    size_t cap = 0;
    for (int j = 0; j < tile->nadj; j++)
        cap += e->store[tile->adj[j]].n;
    *out = malloc((cap ? cap : 1) * 3 * sizeof **out);
    *n = 0;
    if (!*out)
        return -1;
    for (int j = 0; j < tile->nadj; j++) {
        const tile_samples *s = &e->store[tile->adj[j]];
        for (size_t i = 0; i < s->n; i++)
            if (wpd_tile_distance(tile, s->xyz + 3 * i) < dist) {
                memcpy(*out + 3 * *n, s->xyz + 3 * i, 3 * sizeof **out);
                (*n)++;
            }
    }
    return 0;
}

/* Keeps the points idx[0..m-1] of d as tile t's samples. */
static int keep_samples(engine *e, int t, const wpd_tile_data *d, const uint32_t *idx, size_t m)
{
    tile_samples *s = &e->store[t];
    s->n = m;
    s->gid = malloc((m ? m : 1) * sizeof *s->gid);
    s->xyz = malloc((m ? m : 1) * 3 * sizeof *s->xyz);
    if (!s->gid || !s->xyz)
        return -1;
    for (size_t i = 0; i < m; i++) {
        s->gid[i] = d->gid[idx[i]];
        memcpy(s->xyz + 3 * i, d->xyz + 3 * (size_t)idx[i], 3 * sizeof *s->xyz);
    }
    return 0;
}

/* One tile of a full pass at radius r. */
static int poisson_tile(engine *e, int t, double r, wpd_error *err)
{
    wpd_tile_data d;
    if (wpd_spill_read(e->spill, t, 0, &d, err))
        return -1;
    uint32_t *cand = malloc((d.n ? d.n : 1) * sizeof *cand);
    uint32_t *kept = malloc((d.n ? d.n : 1) * sizeof *kept);
    double *fixed = NULL;
    size_t ncand = 0, nfixed = 0;
    int rc = -1;
    if (!cand || !kept || gather_neighbour_samples(e, t, r, &fixed, &nfixed)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
        goto done;
    }
    /* Candidates: the tile's own points, and the halo points of neighbours
     * not yet processed (later colours). The greedy pass over both decides
     * the border points as the pass over the whole cloud would - a point
     * is kept iff no kept point of smaller priority lies within r, and the
     * halo holds the points that decide that - so the tiles reproduce the
     * one-tile result but where a chain of such decisions runs further
     * than the halo. Halo points of finished neighbours are settled: their
     * samples are fixed, the rest are gone. Only own points are kept. */
    int colour = e->plan.tiles[t].colour;
    for (size_t i = 0; i < d.n; i++) {
        int home = d.halo[i] ? e->plan.cell_tile[wpd_scan_cell_of(&e->scan, d.xyz + 3 * i)] : t;
        if (home == t || e->plan.tiles[home].colour > colour)
            cand[ncand++] = (uint32_t)i;
    }
    wpd_poisson_input in = {d.xyz, d.gid, NULL, cand, ncand, fixed, nfixed, r,
                            e->opt->params.seed, 1};
    long m = wpd_poisson_pass(&in, kept, err);
    if (m < 0)
        goto done;
    size_t own = 0;
    for (long i = 0; i < m; i++)
        if (!d.halo[kept[i]])
            kept[own++] = kept[i];
    if (keep_samples(e, t, &d, kept, own)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
        goto done;
    }
    rc = 0;
done:
    free(cand);
    free(kept);
    free(fixed);
    wpd_tile_data_free(&d);
    return rc;
}

/* Runs fn on every tile, colour by colour, the tiles of a colour in
 * parallel. Tiles of one colour are never neighbours, so each sees exactly
 * the work of its neighbours of earlier colours, whatever the threads. */
typedef int (*tile_fn)(engine *e, int t, double r, wpd_error *err);

/* Threads working on tiles: one tile each, at most the tiles the budget
 * holds at once. */
static int tile_threads(const engine *e)
{
    return e->threads < WPD_ENGINE_TILES_IN_FLIGHT ? e->threads : WPD_ENGINE_TILES_IN_FLIGHT;
}

static int for_each_tile_by_colour(engine *e, tile_fn fn, double r, wpd_error *err)
{
    int failed = 0;
    wpd_error first_err = {0};
    for (int c = 0; c < e->plan.ncolours && !failed; c++) {
#pragma omp parallel for num_threads(tile_threads(e)) schedule(dynamic, 1)
        for (int t = 0; t < e->plan.ntiles; t++) {
            if (e->plan.tiles[t].colour != c || failed)
                continue;
            wpd_error local = {0};
            int failed_here = fn(e, t, r, &local);
            wpd_progress_add(e->opt->progress, 1);
            if (failed_here) {
#pragma omp critical
                if (!failed) {
                    failed = 1;
                    first_err = local;
                }
            }
        }
    }
    if (failed && err)
        *err = first_err;
    return failed ? -1 : 0;
}

static int full_pass(engine *e, double r, size_t *count, wpd_error *err)
{
    store_clear(e);
    wpd_progress_phase(e->opt->progress, "poisson", (uint64_t)e->plan.ntiles, "tiles");
    if (for_each_tile_by_colour(e, poisson_tile, r, err))
        return -1;
    wpd_progress_end(e->opt->progress);
    *count = store_count(e);
    e->res->full_passes++;
    return 0;
}

/* The whole sample set as flat arrays (see flatten). */
typedef struct flat_samples {
    size_t n;
    uint64_t *gid;
    double *xyz;
    int *tile;
} flat_samples;

static void flat_free(flat_samples *f)
{
    free(f->gid);
    free(f->xyz);
    free(f->tile);
    memset(f, 0, sizeof *f);
}

/* The whole sample set in global-index order: the order the in-memory
 * path holds its samples in, so that ties (equal distances, common on
 * quantized coordinates) are broken the same way in the pruning and the
 * exact count. */
static int flatten(const engine *e, flat_samples *f)
{
    size_t n = f->n = store_count(e), m = n ? n : 1;
    f->gid = malloc(m * sizeof *f->gid);
    f->xyz = malloc(m * 3 * sizeof *f->xyz);
    f->tile = malloc(m * sizeof *f->tile);
    uint64_t *tk = malloc(m * sizeof *tk);
    uint32_t *from = malloc(m * sizeof *from), *tv = malloc(m * sizeof *tv);
    uint32_t *local = malloc(m * sizeof *local);
    int rc = f->gid && f->xyz && f->tile && tk && from && tv && local ? 0 : -1;
    size_t k = 0;
    for (int t = 0; rc == 0 && t < e->plan.ntiles; t++)
        for (size_t i = 0; i < e->store[t].n; i++, k++) {
            f->gid[k] = e->store[t].gid[i];
            f->tile[k] = t;
            local[k] = (uint32_t)i;
            from[k] = (uint32_t)k;
        }
    if (rc == 0) {
        wpd_radix_sort_u64(f->gid, from, n, 64, tk, tv);
        /* tile of each sorted sample: through tv, then back into f->tile */
        for (size_t j = 0; j < n; j++)
            tv[j] = (uint32_t)f->tile[from[j]];
        for (size_t j = 0; j < n; j++) {
            const tile_samples *s = &e->store[tv[j]];
            memcpy(f->xyz + 3 * j, s->xyz + 3 * (size_t)local[from[j]], 3 * sizeof *f->xyz);
            f->tile[j] = (int)tv[j];
        }
    }
    free(tk);
    free(from);
    free(tv);
    free(local);
    return rc;
}

/* Replaces the store by the samples idx[0..m-1] (ascending) of f. */
static int unflatten(engine *e, const flat_samples *f, const uint32_t *idx, size_t m)
{
    store_clear(e);
    size_t *count = calloc((size_t)e->plan.ntiles, sizeof *count);
    if (!count)
        return -1;
    for (size_t i = 0; i < m; i++)
        count[f->tile[idx[i]]]++;
    int rc = 0;
    for (int t = 0; t < e->plan.ntiles; t++) {
        tile_samples *s = &e->store[t];
        s->gid = malloc((count[t] ? count[t] : 1) * sizeof *s->gid);
        s->xyz = malloc((count[t] ? count[t] : 1) * 3 * sizeof *s->xyz);
        if (!s->gid || !s->xyz)
            rc = -1;
    }
    for (size_t i = 0; i < m && rc == 0; i++) {
        tile_samples *s = &e->store[f->tile[idx[i]]];
        s->gid[s->n] = f->gid[idx[i]];
        memcpy(s->xyz + 3 * s->n, f->xyz + 3 * (size_t)idx[i], 3 * sizeof *s->xyz);
        s->n++;
    }
    free(count);
    return rc;
}

/* An overshooting pass is pruned in memory (wpd_prune_to_range): all
 * samples take part, so the pruned set keeps the Poisson property across
 * tiles too. */
static int prune_to_range(engine *e, double r_lo, wpd_error *err)
{
    flat_samples f = {0};
    uint32_t *kept = NULL;
    int rc = -1;
    if (flatten(e, &f) || !(kept = malloc((f.n ? f.n : 1) * sizeof *kept))) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory pruning %zu samples", f.n);
        goto done;
    }
    store_clear(e); /* f holds everything now: the memory peak is here */
    long m = wpd_prune_to_range(f.xyz, f.gid, NULL, f.n, e->opt->target, r_lo,
                                e->opt->params.seed, e->threads, kept, &e->res->radius,
                                &e->res->prune_passes, err);
    if (m < 0)
        goto done;
    if (unflatten(e, &f, kept, (size_t)m)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory pruning %zu samples", f.n);
        goto done;
    }
    rc = 0;
done:
    flat_free(&f);
    free(kept);
    return rc;
}

/* Full passes with the paper's refinement until the count reaches [n, 1.05 n]
 * or overshoots, which is then pruned in memory. */
static int refine_radius(engine *e, double r0, wpd_error *err)
{
    size_t n = e->opt->target, count = 0;
    wpd_refine st;
    wpd_refine_init(&st, n, r0, e->opt->params.max_passes);
    for (;;) {
        double r = st.r;
        if (full_pass(e, r, &count, err))
            return -1;
        if (e->res->full_passes == 1)
            e->res->first_pass_count = count;
        e->res->radius = r;
        wpd_refine_status s = wpd_refine_report(&st, count);
        if (s == WPD_REFINE_DONE)
            return 0;
        if (count > n)
            return prune_to_range(e, r, err);
        if (s == WPD_REFINE_GAVE_UP)
            return 0;
    }
}

/* ------------------------------------------------------------------ exact count */

static int exact_count(engine *e, wpd_error *err)
{
    flat_samples f = {0};
    uint32_t *idx = NULL;
    int rc = -1;
    if (flatten(e, &f) || !(idx = malloc((f.n ? f.n : 1) * sizeof *idx))) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count");
        goto done;
    }
    store_clear(e); /* f holds everything now: the memory peak is here */
    for (size_t i = 0; i < f.n; i++)
        idx[i] = (uint32_t)i;
    wpd_exact_input in = {f.xyz, f.gid, NULL, 0, e->res->radius, e->threads};
    int sweeps = 0;
    long kept = wpd_exact_count(&in, idx, f.n, e->opt->target, &sweeps, err);
    if (kept < 0)
        goto done;
    if (unflatten(e, &f, idx, (size_t)kept)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count");
        goto done;
    }
    rc = 0;
done:
    flat_free(&f);
    free(idx);
    return rc;
}

/* ------------------------------------------------------------------ smoothing and records */

static int smooth_samples(engine *e, int t, const wpd_tile_data *d, wpd_error *err)
{
    const wpd_params *p = &e->opt->params;
    tile_samples *s = &e->store[t];
    double r = e->res->radius;
    wpd_grid surface = {0};
    double *ctx = NULL;
    size_t nctx = 0;
    int rc = -1;
    double input_dk = 2.5 * r * sqrt((double)e->opt->target / (double)e->res->input_points);
    if (p->keep_on_surface &&
        wpd_grid_build_knn(&surface, d->xyz, NULL, d->n, p->k, input_dk, 1, err))
        goto done;
    /* Context: neighbours' samples within 3 r, at their current positions. */
    if (gather_neighbour_samples(e, t, 3 * r, &ctx, &nctx)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
        goto done;
    }
    wpd_smooth_input in = {s->xyz, s->n, NULL, ctx, nctx,
                           p->keep_on_surface ? &surface : NULL, input_dk,
                           (wpd_smooth_mode)p->smooth_mode, p->k, p->iterations, r, 1,
                           {p->resolution[0], p->resolution[1], p->resolution[2]}};
    wpd_smooth_stats st;
    if (wpd_smooth(&in, &st, err))
        goto done;
#pragma omp atomic
    e->res->open_cells += st.open_cells;
#pragma omp atomic
    e->res->pulled_to_surface += st.pulled_to_surface;
    rc = 0;
done:
    wpd_grid_free(&surface);
    free(ctx);
    return rc;
}

static int finish_tile(engine *e, int t, double r, wpd_error *err)
{
    (void)r;
    if (e->store[t].n == 0)
        return 0;
    const wpd_params *p = &e->opt->params;
    if (!p->smooth || p->iterations <= 0)
        return 0;
    wpd_tile_data d;
    if (wpd_spill_read(e->spill, t, 0, &d, err))
        return -1;
    int rc = smooth_samples(e, t, &d, err);
    wpd_tile_data_free(&d);
    return rc;
}

/* n >= the input: every point is kept as it is. */
static int take_all_tile(engine *e, int t, double r, wpd_error *err)
{
    (void)r;
    wpd_tile_data d;
    if (wpd_spill_read(e->spill, t, 0, &d, err))
        return -1;
    tile_samples *s = &e->store[t];
    s->gid = malloc((d.n ? d.n : 1) * sizeof *s->gid);
    s->xyz = malloc((d.n ? d.n : 1) * 3 * sizeof *s->xyz);
    int rc = 0;
    if (!s->gid || !s->xyz)
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
    for (size_t i = 0; rc == 0 && i < d.n; i++) {
        if (d.halo[i])
            continue;
        s->gid[s->n] = d.gid[i];
        memcpy(s->xyz + 3 * s->n, d.xyz + 3 * i, 3 * sizeof *s->xyz);
        s->n++;
    }
    wpd_tile_data_free(&d);
    return rc;
}

/* ------------------------------------------------------------------ merge */

static int merge(engine *e, wpd_error *err)
{
    wpd_engine_result *res = e->res;
    flat_samples f = {0};
    if (flatten(e, &f)) {
        flat_free(&f);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory merging %zu samples", store_count(e));
    }
    for (size_t j = 0; j < f.n; j++)
        for (int a = 0; a < 3; a++)
            f.xyz[3 * j + a] += e->scan.origin[a];
    res->gid = f.gid;
    res->xyz = f.xyz;
    res->count = f.n;
    free(f.tile);
    return 0;
}

/* Copies the records of samples [lo, hi) (sorted by global index) from
 * cloud, which delivers the points from global index `first` on. */
static int copy_records(engine *e, wpd_cloud *cloud, size_t lo, size_t hi, uint64_t first,
                        wpd_error *err)
{
    wpd_engine_result *res = e->res;
    size_t rs = e->record_size;
    wpd_batch b;
    if (wpd_batch_init(&b, 65536, e->record_size))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu records", res->count);
    size_t next = lo;
    long got = 0;
    while (next < hi && (got = wpd_cloud_read(cloud, &b, NULL, err)) > 0) {
        for (; next < hi && res->gid[next] < first + b.n; next++)
            memcpy(res->records + next * rs, b.records + (res->gid[next] - first) * rs, rs);
        first += b.n;
        wpd_progress_add(e->opt->progress, b.n);
    }
    wpd_batch_free(&b);
    if (next < hi)
        return got < 0 ? -1
                       : wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                                  wpd_cloud_header(cloud, 0)->path);
    return 0;
}

/* Each thread reads the stretch of the inputs that holds its share of the
 * samples, with a cloud of its own positioned there: possible when every
 * record is a point (global index = record index) and the format can
 * seek. Returns 0, -1 with err set, or 1 when it cannot (nothing done). */
static int gather_records_parallel(engine *e, wpd_error *err)
{
    wpd_engine_result *res = e->res;
    size_t batch_bytes = (size_t)65536 * (e->record_size + 24);
    int threads = pass_threads(e->opt->mem_bytes, e->threads,
                               samples_bytes(e->opt->target, e->record_size), batch_bytes);
    if (threads < 2 || res->count < 2 || e->scan.count != wpd_cloud_count(e->cloud))
        return 1;
    int failed = 0, unseekable = 0;
    wpd_error first_err = {0};
#pragma omp parallel num_threads(threads)
    {
        int t = omp_get_thread_num(), nt = omp_get_num_threads();
        size_t lo = res->count * (size_t)t / (size_t)nt;
        size_t hi = res->count * (size_t)(t + 1) / (size_t)nt;
        wpd_error mine = {0};
        wpd_cloud *c = lo < hi ? wpd_cloud_reopen(e->cloud, &mine) : NULL;
        int rc = lo < hi ? (c ? 0 : -1) : 0;
        if (rc == 0 && c && wpd_cloud_seek(c, res->gid[lo], &mine))
            rc = mine.code == WPD_E_USAGE ? 1 : -1;
        if (rc == 0 && c)
            rc = copy_records(e, c, lo, hi, res->gid[lo], &mine);
        wpd_cloud_close(c);
#pragma omp critical(wpd_gather_records)
        {
            if (rc == 1)
                unseekable = 1;
            else if (rc && !failed) {
                failed = 1;
                first_err = mine;
            }
        }
    }
    if (failed) {
        if (err)
            *err = first_err;
        return -1;
    }
    return unseekable ? 1 : 0;
}

/* The records of the samples, from a last streaming pass over the inputs:
 * the samples are sorted by global index, which is the reading order. The
 * tiles hold coordinates only - the records, half the spilled bytes, are
 * needed for the kept 1 % alone (docs/engine.md has the figures). */
static int gather_records(engine *e, wpd_error *err)
{
    wpd_engine_result *res = e->res;
    res->records = malloc((res->count ? res->count : 1) * e->record_size);
    if (!res->records)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu records", res->count);
    int rc = gather_records_parallel(e, err);
    if (rc != 1)
        return rc;
    if (wpd_cloud_rewind(e->cloud, err))
        return -1;
    return copy_records(e, e->cloud, 0, res->count, 0, err);
}

/* ------------------------------------------------------------------ driver */

static double global_radius(const engine *e)
{
    const wpd_params *p = &e->opt->params;
    if (p->radius > 0)
        return p->radius;
    wpd_radius_info ri;
    if (p->radius_method == WPD_RADIUS_PAPER) {
        /* eq. 4 at the counted scale nearest voxel_frac x the longest side */
        double longest = fmax(e->scan.extent[0], fmax(e->scan.extent[1], e->scan.extent[2]));
        int best = 0;
        for (int s = 1; s < e->scan.nscales; s++)
            if (fabs(log(e->scan.edge[s] / (p->voxel_frac * longest))) <
                fabs(log(e->scan.edge[best] / (p->voxel_frac * longest))))
                best = s;
        return wpd_radius_paper_formula((double)e->scan.voxels[best], e->scan.edge[best],
                                        e->opt->target, p->lambda);
    }
    wpd_radius_from_counts(e->scan.edge, e->scan.voxels, e->scan.nscales, e->opt->target,
                           p->density, &ri);
    return ri.radius;
}

static int copy_tile_boxes(engine *e)
{
    double *box = malloc((size_t)e->plan.ntiles * 6 * sizeof *box);
    if (!box)
        return -1;
    for (int t = 0; t < e->plan.ntiles; t++)
        for (int a = 0; a < 3; a++) {
            const wpd_tile *tile = &e->plan.tiles[t];
            double lo = fmax(tile->box_lo[a], 0), hi = fmin(tile->box_hi[a], e->scan.extent[a]);
            box[6 * t + a] = lo + e->scan.origin[a];
            box[6 * t + 3 + a] = hi + e->scan.origin[a];
        }
    e->res->tile_box = box;
    return 0;
}

static int check_budget(const engine *e, uint64_t declared, wpd_error *err)
{
    size_t need = wpd_engine_min_budget(e->opt->target, e->record_size);
    if (e->opt->mem_bytes < need)
        return wpd_fail(err, WPD_E_MEMORY,
                        "memory budget too small: %zu MiB given, at least %zu MiB needed for "
                        "%llu output points from %llu input points (raise --mem or lower -n)",
                        e->opt->mem_bytes >> 20, (need >> 20) + 1,
                        (unsigned long long)e->opt->target, (unsigned long long)declared);
    return 0;
}

static uint64_t max_tile_points(const engine *e)
{
    size_t fixed = FIXED_BYTES + SPILL_BUFFERS_MAX + samples_bytes(e->opt->target, e->record_size);
    size_t left = e->opt->mem_bytes > fixed ? e->opt->mem_bytes - fixed : 0;
    uint64_t m = left / ((size_t)WPD_ENGINE_TILES_IN_FLIGHT *
                         wpd_engine_bytes_per_tile_point(e->record_size));
    return m < MIN_TILE_POINTS ? MIN_TILE_POINTS : m;
}

static int open_spill(engine *e, wpd_error *err)
{
    wpd_spill_options so;
    wpd_spill_default_options(&so);
    /* With one thread, compression runs on the tiling thread itself (no
     * thread beside it); with more, as many compression threads as
     * --threads wait beside the tiling threads. */
    so.threads = e->threads > 1 ? e->threads : 0;
    /* The whole write-buffer budget, whatever the number of tiles: larger
     * chunks compress better, and the peak does not depend on the input's
     * size (a small cloud in few tiles uses as much as a large one). */
    /* Spares within the write-buffer budget where the smallest buffers
     * (64 KB) allow: at least 2 a thread. */
    if (so.threads > 0) {
        size_t room = SPILL_BUFFERS_MAX / (64 << 10), tiles = (size_t)e->plan.ntiles;
        size_t fit = room > tiles ? (room - tiles) / (size_t)so.threads : 0;
        so.spares_per_thread = fit < 2 ? 2 : fit > WPD_SPILL_SPARES_PER_THREAD
                                                  ? WPD_SPILL_SPARES_PER_THREAD
                                                  : (int)fit;
    }
    size_t buffers = (size_t)e->plan.ntiles + (size_t)so.threads * (size_t)so.spares_per_thread;
    size_t per_tile = SPILL_BUFFERS_MAX / buffers;
    so.buffer_bytes = per_tile < (64 << 10) ? (64 << 10) : per_tile > (4 << 20) ? (4 << 20) : per_tile;
    e->spill = wpd_spill_create(e->opt->tmpdir, e->plan.ntiles, 0, &so, err);
    return e->spill ? 0 : -1;
}

static int run_phases(engine *e, wpd_error *err)
{
    wpd_engine_result *res = e->res;
    wpd_engine_timings *tm = &res->time;
    size_t scan_room = e->opt->mem_bytes > FIXED_BYTES ? e->opt->mem_bytes - FIXED_BYTES : 0;
    if (wpd_scan_run(e->cloud, WPD_LADDER_KEYS, e->threads, scan_room, e->opt->progress, &e->scan,
                     err))
        return -1;
    tm->bounds = e->scan.bounds_seconds;
    tm->scan = e->scan.scan_seconds;
    res->input_points = e->scan.count;
    res->nfiles = e->scan.nfiles;
    res->file_count = malloc((size_t)res->nfiles * sizeof *res->file_count);
    if (!res->file_count)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    memcpy(res->file_count, e->scan.file_count, (size_t)res->nfiles * sizeof *res->file_count);

    double t = omp_get_wtime();
    res->radius_estimate = res->radius = global_radius(e);
    /* The halo carries the input surface across borders for smoothing:
     * samples move less than r, and the refinement changes r by little. */
    if (wpd_plan_tiles(&e->scan, max_tile_points(e), e->opt->min_tiles, 2.5 * res->radius,
                       &e->plan, err))
        return -1;
    res->tiles = e->plan.ntiles;
    res->colours = e->plan.ncolours;
    res->largest_tile = e->plan.largest;
    if (copy_tile_boxes(e))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (!(e->store = calloc((size_t)e->plan.ntiles, sizeof *e->store)))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    tm->plan = omp_get_wtime() - t;

    t = omp_get_wtime();
    wpd_progress_phase(e->opt->progress, "tile", e->scan.count, "points");
    if (open_spill(e, err) || tile_pass(e, err))
        return -1;
    wpd_progress_end(e->opt->progress);
    wpd_spill_get_stats(e->spill, &res->spill);
    tm->tile = omp_get_wtime() - t;

    t = omp_get_wtime();
    if (e->opt->target >= e->scan.count) {
        if (for_each_tile_by_colour(e, take_all_tile, 0, err) || merge(e, err))
            return -1;
        return gather_records(e, err);
    }
    if (refine_radius(e, res->radius, err))
        return -1;
    res->poisson_count = store_count(e);
    tm->poisson = omp_get_wtime() - t;

    t = omp_get_wtime();
    if (exact_count(e, err))
        return -1;
    tm->exact = omp_get_wtime() - t;

    t = omp_get_wtime();
    wpd_progress_phase(e->opt->progress, "smooth", (uint64_t)e->plan.ntiles, "tiles");
    if (for_each_tile_by_colour(e, finish_tile, res->radius, err))
        return -1;
    wpd_progress_end(e->opt->progress);
    tm->smooth = omp_get_wtime() - t;

    t = omp_get_wtime();
    wpd_progress_phase(e->opt->progress, "records", e->scan.count, "points");
    if (merge(e, err) || gather_records(e, err))
        return -1;
    wpd_progress_end(e->opt->progress);
    tm->merge = omp_get_wtime() - t;
    return 0;
}

int wpd_engine_run(wpd_cloud *cloud, const wpd_engine_options *opt, wpd_engine_result *res,
                   wpd_error *err)
{
    memset(res, 0, sizeof *res);
    engine e = {.opt = opt, .cloud = cloud, .res = res};
    e.record_size = wpd_cloud_header(cloud, 0)->schema.record_size;
    e.threads = opt->params.threads > 0 ? opt->params.threads : omp_get_max_threads();
    res->record_size = e.record_size;
    double t0 = omp_get_wtime();
    if (opt->target < 1)
        return wpd_fail(err, WPD_E_USAGE, "the target count must be at least 1");
    if (check_budget(&e, wpd_cloud_count(cloud), err))
        return -1;
    int rc = run_phases(&e, err);
    store_clear(&e);
    free(e.store);
    wpd_spill_destroy(e.spill);
    wpd_plan_free(&e.plan);
    wpd_scan_free(&e.scan);
    if (rc)
        wpd_engine_result_free(res);
    else
        res->time.total = omp_get_wtime() - t0;
    return rc;
}

void wpd_engine_result_free(wpd_engine_result *res)
{
    free(res->gid);
    free(res->xyz);
    free(res->records);
    free(res->file_count);
    free(res->tile_box);
    memset(res, 0, sizeof *res);
}
