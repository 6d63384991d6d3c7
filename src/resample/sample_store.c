/* sample_store.c - each tile's samples (sample_store.h): held
 * in memory for a cloud resampled in memory, else in files (one run of a
 * spill/runs.h set per tile) with a second set holding each tile's border:
 * the samples a neighbour's view can need, read without the whole tile. */
#include "resample/sample_store.h"
#include "resample/run.h"

#include <stdlib.h>
#include <string.h>

int wpd_samples_alloc(wpd_tile_samples *s, size_t n, int with_edge)
{
    size_t m = n ? n : 1;
    memset(s, 0, sizeof *s);
    s->gid = malloc(m * sizeof *s->gid);
    s->xyz = malloc(3 * m * sizeof *s->xyz);
    s->edge = with_edge ? calloc(m, 1) : NULL;
    return s->gid && s->xyz && (s->edge || !with_edge) ? 0 : -1;
}

void wpd_samples_free(wpd_tile_samples *s)
{
    free(s->gid);
    free(s->xyz);
    free(s->edge);
    memset(s, 0, sizeof *s);
}

int wpd_store_open(wpd_run *run, wpd_error *err)
{
    int ntiles = run->plan.ntiles;
    run->store = calloc((size_t)ntiles, sizeof *run->store);
    run->count = calloc((size_t)ntiles, sizeof *run->count);
    if (!run->store || !run->count)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (run->res->in_memory)
        return 0;
    wpd_runs_options o = {.dir = run->opt->tmpdir ? run->opt->tmpdir : ".",
                          .with_edge = run->p->sharp};
    if (wpd_runs_open(&o, &run->files, err) || wpd_runs_reserve(run->files, ntiles, err) ||
        wpd_runs_open(&o, &run->border, err) || wpd_runs_reserve(run->border, ntiles, err))
        return -1;
    return 0;
}

void wpd_store_close(wpd_run *run)
{
    for (int t = 0; run->store && t < run->plan.ntiles; t++)
        wpd_samples_free(&run->store[t]);
    free(run->store);
    free(run->count);
    wpd_runs_close(run->files);
    wpd_runs_close(run->border);
    run->store = NULL, run->count = NULL, run->files = run->border = NULL;
}

size_t wpd_store_count(const wpd_run *run, int t)
{
    return run->files ? run->count[t] : run->store[t].n;
}

size_t wpd_run_store_count(const wpd_run *run)
{
    size_t total = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        total += wpd_store_count(run, t);
    return total;
}

int wpd_store_labelled(const wpd_run *run)
{
    if (run->files)
        return wpd_runs_with_edge(run->files);
    for (int t = 0; t < run->plan.ntiles; t++)
        if (run->store[t].edge)
            return 1;
    return 0;
}

void wpd_run_store_clear(wpd_run *run)
{
    for (int t = 0; run->store && t < run->plan.ntiles; t++) {
        wpd_samples_free(&run->store[t]);
        run->count[t] = 0;
        if (run->files) {
            wpd_runs_clear(run->files, t);
            wpd_runs_clear(run->border, t);
        }
    }
}

int wpd_store_load(wpd_run *run, int t, wpd_error *err)
{
    wpd_tile_samples *s = &run->store[t];
    if (!run->files || s->gid)
        return 0;
    return wpd_runs_read(run->files, t, &s->gid, &s->xyz, &s->edge, &s->n, err);
}

void wpd_store_drop(wpd_run *run, int t)
{
    if (run->files)
        wpd_samples_free(&run->store[t]);
}

int wpd_store_finish(wpd_run *run, int t, int rc, wpd_error *err)
{
    if (rc == 0)
        return wpd_store_save(run, t, err);
    wpd_store_drop(run, t);
    return rc;
}

/* Which samples a subset keeps: those within dist of the faces of tile's
 * box or outside it (faces set: a border), else those within dist of the
 * box. */
typedef struct where {
    const wpd_tile *tile;
    double dist;
    int faces;
} where;

static int keeps(const where *w, const double *p)
{
    return w->faces ? wpd_tile_near_faces(w->tile, p, w->dist)
                    : wpd_tile_distance(w->tile, p) <= w->dist;
}

/* The samples of src that w keeps, in order, into out (malloc'd). Returns
 * 0 or -1 (out of memory). */
static int subset(const wpd_tile_samples *src, const where *w, wpd_tile_samples *out)
{
    size_t m = 0;
    for (size_t i = 0; i < src->n; i++)
        m += keeps(w, src->xyz + 3 * i);
    if (wpd_samples_alloc(out, m, src->edge != NULL))
        return -1;
    for (size_t i = 0; i < src->n; i++)
        if (keeps(w, src->xyz + 3 * i)) {
            out->gid[out->n] = src->gid[i];
            memcpy(out->xyz + 3 * out->n, src->xyz + 3 * i, 3 * sizeof *out->xyz);
            if (out->edge)
                out->edge[out->n] = src->edge[i];
            out->n++;
        }
    return 0;
}

/* Tile t's border: its samples within the band of its box's faces (or
 * outside the box: smoothing may have moved them there). */
static int save_border(wpd_run *run, int t, const wpd_tile_samples *s, wpd_error *err)
{
    where w = {&run->plan.tiles[t], WPD_STORE_BAND * run->halo, 1};
    wpd_tile_samples b;
    if (subset(s, &w, &b)) {
        wpd_samples_free(&b);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
    }
    return wpd_runs_put(run->border, t, b.gid, b.xyz, b.edge, b.n, err);
}

int wpd_store_save(wpd_run *run, int t, wpd_error *err)
{
    wpd_tile_samples *s = &run->store[t];
    if (!run->files)
        return 0;
    run->count[t] = s->n;
    int rc = save_border(run, t, s, err);
    /* put takes the arrays in every case */
    if (wpd_runs_put(run->files, t, s->gid, s->xyz, s->edge, s->n, rc ? NULL : err))
        rc = -1;
    memset(s, 0, sizeof *s);
    return rc;
}

int wpd_store_near(const wpd_run *run, int t, int u, double dist, wpd_tile_samples *out,
                   wpd_error *err)
{
    memset(out, 0, sizeof *out);
    where w = {&run->plan.tiles[t], dist, 0};
    /* In files, never the copy u's own thread may hold (and free) now. */
    if (!run->files)
        return subset(&run->store[u], &w, out)
                   ? wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t) : 0;
    wpd_tile_samples b = {0};
    if (wpd_runs_read(run->border, u, &b.gid, &b.xyz, &b.edge, &b.n, err))
        return -1;
    int rc = subset(&b, &w, out);
    wpd_samples_free(&b);
    return rc ? wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t) : 0;
}

int wpd_run_neighbour_samples(const wpd_run *run, int t, double dist, double **out,
                              uint8_t **edge, size_t *n, wpd_error *err)
{
    const wpd_tile *tile = &run->plan.tiles[t];
    wpd_tile_samples *near = calloc((size_t)(tile->nadj ? tile->nadj : 1), sizeof *near);
    size_t cap = 0;
    int labelled = 0, rc = near ? 0 : wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (int j = 0; rc == 0 && j < tile->nadj; j++) {
        rc = wpd_store_near(run, t, tile->adj[j], dist, &near[j], err);
        cap += near[j].n;
        labelled |= near[j].edge != NULL;
    }
    *out = rc ? NULL : malloc((cap ? cap : 1) * 3 * sizeof **out);
    *edge = rc == 0 && labelled ? calloc(cap ? cap : 1, 1) : NULL;
    *n = 0;
    if (rc == 0 && (!*out || (labelled && !*edge)))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory in tile %d", t);
    for (int j = 0; rc == 0 && j < tile->nadj; j++) {
        memcpy(*out + 3 * *n, near[j].xyz, 3 * near[j].n * sizeof **out);
        if (near[j].edge)
            memcpy(*edge + *n, near[j].edge, near[j].n);
        *n += near[j].n;
    }
    for (int j = 0; near && j < tile->nadj; j++)
        wpd_samples_free(&near[j]);
    free(near);
    return rc;
}
