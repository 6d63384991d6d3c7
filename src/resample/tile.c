/* tile.c - the tile pass: every point to its home tile and, within the
 * halo, to its neighbours (routing), on every thread, appended in reading
 * order (the ordered parallel tiler). */
#include "resample/run.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "common/testhook.h"
#include "resample/budget.h"


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
static int route_batch(const wpd_run *e, const double *fxyz, size_t n, routing *r)
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
static int append_groups(wpd_run *e, const routing *r, wpd_error *err)
{
    for (int t = 0; t < e->plan.ntiles; t++) {
        size_t b = r->start[t], m = r->start[t + 1] - b;
        if (m && wpd_tiles_append(&e->tiles, t, r->gid + b, r->xyz + 3 * b, r->hflag + b, m,
                                  err))
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
    wpd_run *e;
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


static int lane_init(tiler_lane *l, const wpd_run *e)
{
    memset(l, 0, sizeof *l);
    l->fxyz = malloc(3 * WPD_BATCH_POINTS * sizeof *l->fxyz);
    /* Halo copies: a point lands in at most a few tiles; grow on demand. */
    return l->fxyz && wpd_batch_init(&l->batch, WPD_BATCH_POINTS, e->record_size) == 0 &&
                   routing_reserve(&l->r, 2 * WPD_BATCH_POINTS, e->plan.ntiles) == 0
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
static int lane_route(const wpd_run *e, tiler_lane *l, uint64_t first_gid)
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
    wpd_run *e = tl->e;
    pthread_mutex_lock(&tl->mu);
    while (tl->next_append != seq)
        pthread_cond_wait(&tl->turn, &tl->mu);
    int failed = tl->failed;
    pthread_mutex_unlock(&tl->mu);
    wpd_error err = {0};
    if (!failed && append_groups(e, &l->r, &err))
        tiler_fail(tl, &err);
    wpd_progress_add(e->opt->progress, l->batch.n);
    if (seq == 0) /* once, when the first points are in (not per batch) */
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

int wpd_tile_pass(wpd_run *e, wpd_error *err)
{
    tiler tl = {.e = e};
    if (wpd_cloud_rewind(e->cloud, err))
        return -1;
    pthread_mutex_init(&tl.mu, NULL);
    pthread_cond_init(&tl.turn, NULL);
    /* A lane: batch, frame coordinates and routing for twice its points. */
    size_t lane_bytes = (size_t)WPD_BATCH_POINTS * (e->record_size + 48) + 2 * (size_t)WPD_BATCH_POINTS * 42;
    int lanes = wpd_budget_pass_threads(e->opt->mem_bytes, e->threads, WPD_BUDGET_SPILL_BUFFERS,
                                        lane_bytes);
#pragma omp parallel num_threads(lanes)
    tiler_lane_run(&tl);
    pthread_mutex_destroy(&tl.mu);
    pthread_cond_destroy(&tl.turn);
    if (tl.failed) {
        if (err)
            *err = tl.err;
        return -1;
    }
    return wpd_tiles_finish(&e->tiles, err);
}

