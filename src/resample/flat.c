/* flat.c - the flat sample set (flat.h), and the exact count, which works
 * on it: it sees every sample at once (and, in each sweep, every tile's
 * input points), so it gives the same samples whatever the tiling. */
#include "resample/flat.h"

#include <stdlib.h>
#include <string.h>

#include "wpd/eliminate.h"

void wpd_flat_free(wpd_flat *f)
{
    free(f->gid);
    free(f->xyz);
    free(f->edge);
    free(f->tile);
    memset(f, 0, sizeof *f);
}

/* A min-heap of tiles keyed by the gid of their next sample. */
typedef struct head {
    uint64_t gid;
    int tile;
} head;

static void sift_down(head *h, size_t n, size_t i)
{
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= n)
            return;
        if (c + 1 < n && h[c + 1].gid < h[c].gid)
            c++;
        if (h[i].gid <= h[c].gid)
            return;
        head tmp = h[i];
        h[i] = h[c];
        h[c] = tmp;
        i = c;
    }
}

/* Whether the samples carry sharp labels (not when every point was kept). */
static int labelled(const wpd_run *run)
{
    for (int t = 0; t < run->plan.ntiles; t++)
        if (run->store[t].edge)
            return 1;
    return 0;
}

/* Each tile's samples ascend by gid: a merge of the tiles gives the flat
 * set in gid order with one heap entry per tile, not a sort with its index
 * arrays (24 bytes a sample at the run's memory peak). */
int wpd_flat_from_store(const wpd_run *run, wpd_flat *f)
{
    int ntiles = run->plan.ntiles;
    size_t n = f->n = wpd_run_store_count(run), m = n ? n : 1;
    int with_edge = labelled(run);
    f->gid = malloc(m * sizeof *f->gid);
    f->xyz = malloc(m * 3 * sizeof *f->xyz);
    f->edge = with_edge ? malloc(m) : NULL;
    f->tile = malloc(m * sizeof *f->tile);
    size_t *next = calloc((size_t)ntiles, sizeof *next);
    head *h = malloc((size_t)(ntiles ? ntiles : 1) * sizeof *h);
    int rc = f->gid && f->xyz && f->tile && (f->edge || !with_edge) && next && h ? 0 : -1;
    size_t nh = 0;
    for (int t = 0; rc == 0 && t < ntiles; t++)
        if (run->store[t].n)
            h[nh++] = (head){run->store[t].gid[0], t};
    for (size_t i = nh; i-- > 0;)
        sift_down(h, nh, i);
    for (size_t j = 0; rc == 0 && j < n; j++) {
        int t = h[0].tile;
        const wpd_tile_samples *s = &run->store[t];
        size_t i = next[t]++;
        f->gid[j] = s->gid[i];
        memcpy(f->xyz + 3 * j, s->xyz + 3 * i, 3 * sizeof *f->xyz);
        if (f->edge)
            f->edge[j] = s->edge ? s->edge[i] : 0;
        f->tile[j] = t;
        if (next[t] < s->n)
            h[0].gid = s->gid[next[t]];
        else
            h[0] = h[--nh];
        sift_down(h, nh, 0);
    }
    free(next);
    free(h);
    return rc;
}

int wpd_flat_to_store(wpd_run *run, const wpd_flat *f, const uint32_t *idx, size_t m)
{
    wpd_run_store_clear(run);
    size_t *count = calloc((size_t)run->plan.ntiles, sizeof *count);
    if (!count)
        return -1;
    for (size_t i = 0; i < m; i++)
        count[f->tile[idx[i]]]++;
    int rc = 0;
    for (int t = 0; t < run->plan.ntiles; t++)
        if (wpd_samples_alloc(&run->store[t], count[t], f->edge != NULL))
            rc = -1;
    for (size_t i = 0; i < m && rc == 0; i++) {
        wpd_tile_samples *s = &run->store[f->tile[idx[i]]];
        s->gid[s->n] = f->gid[idx[i]];
        memcpy(s->xyz + 3 * s->n, f->xyz + 3 * (size_t)idx[i], 3 * sizeof *s->xyz);
        if (f->edge)
            s->edge[s->n] = f->edge[idx[i]];
        s->n++;
    }
    free(count);
    return rc;
}

/* The flat set with the store freed (the memory peak is here) and room for
 * an index list; on failure err is set. */
static int take_flat(wpd_run *run, wpd_flat *f, uint32_t **idx, const char *what,
                     wpd_error *err)
{
    if (wpd_flat_from_store(run, f) || !(*idx = malloc((f->n ? f->n : 1) * sizeof **idx)))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %s of %zu samples", what, f->n);
    wpd_run_store_clear(run);
    return 0;
}

/* One tile's own input points into the costs of a sweep. */
static int cost_tile(wpd_run *run, int t, int threads, void *arg, wpd_error *err)
{
    wpd_tile_data d;
    if (wpd_tiles_read(&run->tiles, t, &d, err))
        return -1;
    wpd_eliminate_add_points(arg, d.xyz, d.halo, d.n, threads);
    wpd_tiles_release(&run->tiles, &d);
    return 0;
}

/* Coverage-aware elimination down to n (eliminate.h): every sweep hands
 * every tile's input points in once. */
int wpd_exact_phase(wpd_run *run, wpd_error *err)
{
    wpd_flat f = {0};
    uint32_t *idx = NULL;
    wpd_eliminate e = {0};
    int rc = -1;
    if (take_flat(run, &f, &idx, "the exact count", err) ||
        wpd_eliminate_init(&e, f.xyz, f.edge, f.n, run->res->radius, run->threads, err))
        goto done;
    while (e.live > run->opt->target) {
        if (wpd_eliminate_begin(&e, err) ||
            wpd_run_tiles_any_order(run, NULL, cost_tile, &e, err) ||
            wpd_eliminate_sweep(&e, run->opt->target, err) < 0)
            goto done;
        run->res->exact_sweeps++;
    }
    size_t kept = wpd_eliminate_result(&e, idx);
    if (wpd_flat_to_store(run, &f, idx, kept)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the exact count");
        goto done;
    }
    rc = 0;
done:
    wpd_eliminate_free(&e);
    wpd_flat_free(&f);
    free(idx);
    return rc;
}
