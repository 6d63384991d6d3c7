/* tile.c - the tile pass: every point to its home tile and, within the
 * halo, to its neighbours (routing), on every thread, appended in reading
 * order (an ordered pass, pass.h).
 *
 * The ranks of an MPI run that share the tiles (docs/scale-out.md): where
 * the scan counted the points of each reading unit, each rank reads one
 * block of units (about N / K points, in order), spills its points for
 * every tile into an outbox, and the outboxes go tile by tile to the
 * tiles' owners (tile_share.c); elsewhere (inputs that cannot seek) each
 * rank reads everything and keeps its own tiles' points. */
#include "resample/tile.h"
#include "resample/run.h"

#include <stdlib.h>
#include <string.h>

#include "common/testhook.h"
#include "resample/budget.h"
#include "io/pass.h"
#include "resample/ranks.h"
#include "resample/tile_share.h"

/* Spill files with the whole write-buffer budget, whatever the number of
 * tiles (larger chunks compress better; the peak does not depend on the
 * input's size). With one thread, compression runs on the tiling thread;
 * with more, as many compression threads wait beside the tilers, each with
 * spares within the write budget where 64 KB buffers allow (at least 2). */
int wpd_run_open_spill(wpd_run *run, wpd_tiles *tiles, wpd_error *err)
{
    wpd_spill_options so;
    wpd_spill_default_options(&so);
    so.threads = run->threads > 1 ? run->threads : 0;
    if (so.threads > 0) {
        size_t room = WPD_BUDGET_SPILL_BUFFERS / (64 << 10), tiles = (size_t)run->plan.ntiles;
        size_t fit = room > tiles ? (room - tiles) / (size_t)so.threads : 0;
        so.spares_per_thread = fit < 2 ? 2 : fit > WPD_SPILL_SPARES_PER_THREAD
                                                  ? WPD_SPILL_SPARES_PER_THREAD
                                                  : (int)fit;
    }
    size_t buffers = (size_t)run->plan.ntiles + (size_t)so.threads * (size_t)so.spares_per_thread;
    size_t per_tile = WPD_BUDGET_SPILL_BUFFERS / buffers;
    so.buffer_bytes = per_tile < (64 << 10) ? (64 << 10) : per_tile > (4 << 20) ? (4 << 20) : per_tile;
    return wpd_tiles_open_spill(tiles, run->opt->tmpdir, run->plan.ntiles, &so, err);
}

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

/* Whether each rank reads a block of the inputs (above). */
static int reads_block(const wpd_run *e)
{
    return wpd_run_spills_own_tiles(e) && e->res->unit_points;
}

/* Whether this process keeps tile t's points: all of them, but where the
 * ranks of an MPI run each read everything, only its own tiles'. */
static int kept_here(const wpd_run *e, int t)
{
    return !wpd_run_spills_own_tiles(e) || reads_block(e) || wpd_run_owns(e, t);
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
        if (kept_here(e, home) && route_point(r, (uint32_t)home, (uint32_t)i, 0))
            return -1;
        if (deep_inside(t, p, pl->halo))
            continue;
        for (int j = 0; j < t->nadj; j++)
            if (wpd_tile_distance2(&pl->tiles[t->adj[j]], p) < halo2 &&
                kept_here(e, t->adj[j]) && route_point(r, (uint32_t)t->adj[j], (uint32_t)i, 1))
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

/* Appends the grouped entries of global index below end to their tiles in
 * dest. A group holds its entries in reading order, so those at or past
 * end are its tail. */
static int append_groups(const wpd_run *e, wpd_tiles *dest, const routing *r, uint64_t end,
                         wpd_error *err)
{
    for (int t = 0; t < e->plan.ntiles; t++) {
        size_t b = r->start[t], m = r->start[t + 1] - b;
        while (m && r->gid[b + m - 1] >= end)
            m--;
        if (m && wpd_tiles_append(dest, t, r->gid + b, r->xyz + 3 * b, r->hflag + b, m, err))
            return -1;
    }
    return 0;
}

/* The tile pass is an ordered pass (pass.h): each lane converts, routes
 * and groups a batch on its own, in parallel; the commits append the
 * groups to the tiles in reading order, so every tile holds its points in
 * global-index order, whatever the threads. */

/* One lane's buffers. */
typedef struct tiler_lane {
    double *fxyz;             /* the batch in frame coordinates */
    routing r;
} tiler_lane;

typedef struct tiler {
    wpd_run *e;
    tiler_lane *lanes;        /* [lanes] */
    wpd_tiles *dest;          /* the run's tiles, or a rank's outbox */
    uint64_t end_gid;         /* a rank's block ends before this global index */
    int stalled;              /* the test hook's stall was passed (commits only) */
} tiler;

static int lane_init(tiler_lane *l, const wpd_run *e)
{
    memset(l, 0, sizeof *l);
    l->fxyz = malloc(3 * WPD_BATCH_POINTS * sizeof *l->fxyz);
    /* Halo copies: a point lands in at most a few tiles; grow on demand. */
    return l->fxyz && routing_reserve(&l->r, 2 * WPD_BATCH_POINTS, e->plan.ntiles) == 0 ? 0
                                                                                        : -1;
}

static void lane_free(tiler_lane *l)
{
    routing_free(&l->r);
    free(l->fxyz);
}

/* Converts to frame coordinates, routes and groups the batch. Global
 * indices are counted from the batch's first point: with parallel reading
 * its own is only known at the commit. */
static int tile_lane(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    tiler *tl = arg;
    const wpd_run *e = tl->e;
    tiler_lane *l = &tl->lanes[pb->lane];
    const wpd_batch *b = pb->batch;
    for (size_t i = 0; i < b->n; i++)
        for (int a = 0; a < 3; a++)
            l->fxyz[3 * i + a] = b->xyz[3 * i + a] - e->scan.origin[a];
    while (route_batch(e, l->fxyz, b->n, &l->r))
        if (routing_reserve(&l->r, 2 * l->r.cap, e->plan.ntiles))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for tiling");
    group_by_tile(&l->r, e->plan.ntiles, l->fxyz, 0);
    return 0;
}

/* Appends the routed batch, in reading order. */
static int tile_commit(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    tiler *tl = arg;
    routing *r = &tl->lanes[pb->lane].r;
    if (pb->first_gid >= tl->end_gid) /* the next rank's block */
        return 1;
    for (size_t k = 0; k < r->n; k++)
        r->gid[k] += pb->first_gid;
    /* A batch may run past the block's end (batches count finite points,
     * units records): its points from end_gid on are the next rank's. */
    if (append_groups(tl->e, tl->dest, r, tl->end_gid, err))
        return -1;
    if (!tl->stalled) { /* once, when the first points are in (not per batch) */
        tl->stalled = 1;
        wpd_test_stall("tile");
    }
    return 0;
}

/* This rank's block: the units from *first_unit (whose first point has
 * global index *first_gid) up to global index *end_gid, about N / K
 * points; the blocks of the ranks follow each other. */
static void block_of(const wpd_run *e, uint64_t *first_unit, uint64_t *first_gid,
                     uint64_t *end_gid)
{
    const wpd_resample_result *res = e->res;
    uint64_t n = e->scan.count, ranks = (uint64_t)wpd_par_ranks(e->opt->par);
    uint64_t r = (uint64_t)wpd_par_rank(e->opt->par);
    uint64_t lo = (uint64_t)((unsigned __int128)n * r / ranks);
    uint64_t hi = (uint64_t)((unsigned __int128)n * (r + 1) / ranks);
    *first_unit = res->nunits, *first_gid = *end_gid = n;
    uint64_t at = 0;
    for (uint64_t u = 0; u < res->nunits; u++) {
        if (at >= lo && *first_unit == res->nunits)
            *first_unit = u, *first_gid = at;
        if (at >= hi && r + 1 < ranks) {
            *end_gid = at;
            break;
        }
        at += res->unit_points[u];
    }
}

/* The ordered pass over the inputs (a rank's block where it reads one)
 * into tl->dest. */
static int read_into(tiler *tl, int lanes, wpd_error *err)
{
    wpd_run *e = tl->e;
    wpd_pass pass = {.cloud = e->cloud, .threads = lanes, .lane = tile_lane,
                     .commit = tile_commit, .arg = tl, .progress = e->opt->progress};
    tl->end_gid = UINT64_MAX;
    if (reads_block(e)) {
        block_of(e, &pass.first_unit, &pass.first_gid, &tl->end_gid);
        if (pass.first_gid >= tl->end_gid) /* an empty block */
            return 0;
    }
    return wpd_pass_run(&pass, err);
}

/* A rank's block into an outbox of every tile, then to the owners. */
static int read_block(tiler *tl, int lanes, wpd_error *err)
{
    wpd_tiles outbox = {0};
    if (wpd_run_open_spill(tl->e, &outbox, err))
        return -1;
    tl->dest = &outbox;
    int rc = read_into(tl, lanes, err) || wpd_tiles_finish(&outbox, err) ? -1 : 0;
    /* A rank that failed goes to the closing agreement, where the others'
     * next agreement meets it (par.h). */
    if (rc == 0)
        rc = wpd_run_send_tiles(tl->e, &outbox, err);
    wpd_tiles_close(&outbox);
    return rc;
}

int wpd_tile_pass(wpd_run *e, wpd_error *err)
{
    /* A lane of its own: frame coordinates and routing for twice its
     * points, beside the pass's batch and cloud. */
    size_t lane_bytes = (size_t)WPD_BATCH_POINTS * 24 + 2 * (size_t)WPD_BATCH_POINTS * 42 +
                        wpd_pass_lane_bytes(e->cloud);
    int lanes = wpd_budget_pass_threads(e->opt->mem_bytes, e->threads, WPD_BUDGET_SPILL_BUFFERS,
                                        lane_bytes);
    tiler tl = {e, calloc((size_t)lanes, sizeof(tiler_lane)), &e->tiles, UINT64_MAX, 0};
    int rc = tl.lanes ? 0 : -1;
    for (int l = 0; rc == 0 && l < lanes; l++)
        rc = lane_init(&tl.lanes[l], e);
    if (rc)
        wpd_fail(err, WPD_E_MEMORY, "out of memory for tiling");
    else
        rc = reads_block(e) ? read_block(&tl, lanes, err) : read_into(&tl, lanes, err);
    for (int l = 0; tl.lanes && l < lanes; l++)
        lane_free(&tl.lanes[l]);
    free(tl.lanes);
    return rc ? -1 : wpd_tiles_finish(&e->tiles, err);
}
