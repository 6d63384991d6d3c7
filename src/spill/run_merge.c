/* run_merge.c - the k-way merge of run_merge.h: a min-heap of runs keyed
 * by their next gid, each run read one chunk at a time, and the levels that
 * bring file runs down to the fan-in first. */
#include "spill/run_merge.h"

#include <stdlib.h>
#include <string.h>

#include "spill/codec.h"
#include "spill/runs_impl.h"

/* One run being merged: its reader, its current chunk and the position in
 * it. */
typedef struct slot {
    wpd_run_reader reader;
    wpd_sample_view chunk;
    size_t at;
} slot;

/* A merge of some runs of a set into an output buffer of one chunk. */
typedef struct merger {
    wpd_runs *rs;
    wpd_run_decoder *dec;     /* NULL in memory */
    slot *slots;
    int *heap;                /* slots with samples left, by next gid (then slot) */
    int nheap;
    uint64_t *gid;            /* output: one chunk */
    double *xyz;
    uint8_t *edge;
    uint64_t left, last;
    int emitted;              /* last holds a gid */
} merger;

struct wpd_run_merge {
    merger m;
    int nslots;
    int levels;
};

static size_t encoder_bytes(size_t chunk_points)
{
    return wpd_coords_bound(chunk_points) + ZSTD_compressBound(wpd_coords_bound(chunk_points)) +
           chunk_points * (1 + 2 * sizeof(uint64_t)) + RUNS_CCTX_BYTES;
}

int wpd_run_merge_fan_in(size_t chunk_points, size_t budget)
{
    size_t fixed = wpd_run_decoder_bytes(chunk_points) + encoder_bytes(chunk_points) +
                   chunk_points * WPD_RUNS_SAMPLE_BYTES;
    size_t per_run = chunk_points * WPD_RUNS_SAMPLE_BYTES + sizeof(slot) + sizeof(int);
    size_t f = budget > fixed ? (budget - fixed) / per_run : 0;
    return f < 2 ? 2 : f > (1 << 20) ? (1 << 20) : (int)f;
}

static uint64_t next_gid(const merger *g, int s)
{
    return g->slots[s].chunk.gid[g->slots[s].at];
}

static int before(const merger *g, int a, int b)
{
    uint64_t ga = next_gid(g, a), gb = next_gid(g, b);
    return ga < gb || (ga == gb && a < b);
}

static void sift_down(merger *g, int i)
{
    for (;;) {
        int c = 2 * i + 1;
        if (c >= g->nheap)
            return;
        if (c + 1 < g->nheap && before(g, g->heap[c + 1], g->heap[c]))
            c++;
        if (!before(g, g->heap[c], g->heap[i]))
            return;
        int t = g->heap[i];
        g->heap[i] = g->heap[c];
        g->heap[c] = t;
        i = c;
    }
}

static void merger_free(merger *g, int nslots)
{
    for (int s = 0; g->slots && s < nslots; s++)
        wpd_run_reader_close(&g->slots[s].reader);
    free(g->slots);
    free(g->heap);
    free(g->gid);
    free(g->xyz);
    free(g->edge);
    wpd_run_decoder_free(g->dec);
    memset(g, 0, sizeof *g);
}

/* Slot s's next chunk; s leaves the heap's candidates when its run ends.
 * Returns 1 when it has samples, 0 when not, -1 on failure. */
static int refill(merger *g, int s, wpd_error *err)
{
    slot *sl = &g->slots[s];
    sl->at = 0;
    if (wpd_run_reader_next(&sl->reader, g->dec, &sl->chunk, err))
        return -1;
    return sl->chunk.n > 0;
}

/* A merger over runs ids[0..k-1] of rs. */
static int merger_init(merger *g, wpd_runs *rs, const int *ids, int k, wpd_error *err)
{
    size_t cap = rs->chunk_points;
    memset(g, 0, sizeof *g);
    g->rs = rs;
    g->slots = calloc((size_t)(k ? k : 1), sizeof *g->slots);
    g->heap = malloc((size_t)(k ? k : 1) * sizeof *g->heap);
    g->gid = malloc(cap * sizeof *g->gid);
    g->xyz = malloc(3 * cap * sizeof *g->xyz);
    g->edge = rs->with_edge ? malloc(cap) : NULL;
    g->dec = rs->in_files ? wpd_run_decoder_new(rs) : NULL;
    if (!g->slots || !g->heap || !g->gid || !g->xyz || (rs->with_edge && !g->edge) ||
        (rs->in_files && !g->dec)) {
        merger_free(g, 0);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory to merge %d runs", k);
    }
    for (int s = 0; s < k; s++) {
        wpd_run_reader_open(&g->slots[s].reader, rs, ids[s]);
        g->left += rs->runs[ids[s]].n;
    }
    for (int s = 0; s < k; s++) {
        int has = refill(g, s, err);
        if (has < 0) {
            merger_free(g, k);
            return -1;
        }
        if (has)
            g->heap[g->nheap++] = s;
    }
    for (int i = g->nheap / 2; i-- > 0;)
        sift_down(g, i);
    return 0;
}

/* Moves the heap's first sample to output position j; advances its slot. */
static int take_first(merger *g, size_t j, wpd_error *err)
{
    int s = g->heap[0];
    slot *sl = &g->slots[s];
    uint64_t gid = sl->chunk.gid[sl->at];
    if (g->emitted && gid <= g->last)
        return wpd_fail(err, WPD_E_INPUT, "%s: global index %llu in two runs (internal error)",
                        g->rs->in_files ? g->rs->dir : "run merge", (unsigned long long)gid);
    g->gid[j] = g->last = gid;
    g->emitted = 1;
    memcpy(g->xyz + 3 * j, sl->chunk.xyz + 3 * sl->at, 3 * sizeof *g->xyz);
    if (g->edge)
        g->edge[j] = sl->chunk.edge ? sl->chunk.edge[sl->at] : 0;
    if (++sl->at == sl->chunk.n) {
        int has = refill(g, s, err);
        if (has < 0)
            return -1;
        if (!has)
            g->heap[0] = g->heap[--g->nheap];
    }
    sift_down(g, 0);
    return 0;
}

static int merger_next(merger *g, uint64_t end, wpd_sample_view *v, wpd_error *err)
{
    size_t n = 0, cap = g->rs->chunk_points;
    while (n < cap && g->nheap && next_gid(g, g->heap[0]) < end)
        if (take_first(g, n++, err))
            return -1;
    g->left -= n;
    *v = (wpd_sample_view){n, g->gid, g->xyz, g->edge};
    return 0;
}

/* Merges runs ids[0..k-1] into a new run of the set (its id in *into) and
 * clears them. */
static int merge_level(wpd_runs *rs, const int *ids, int k, int *into, wpd_error *err)
{
    merger g;
    if (wpd_runs_add(rs, into, err) || merger_init(&g, rs, ids, k, err))
        return -1;
    int rc = 0;
    for (wpd_sample_view v = {0}; rc == 0;) {
        if ((rc = merger_next(&g, UINT64_MAX, &v, err)) || v.n == 0)
            break;
        rc = wpd_runs_append(rs, *into, &v, err);
    }
    merger_free(&g, k);
    for (int s = 0; rc == 0 && s < k; s++)
        wpd_runs_clear(rs, ids[s]);
    return rc;
}

/* ids[] by ascending length (then id), for picking the smallest runs. */
static void sort_by_length(const wpd_runs *rs, int *ids, int n)
{
    for (int i = 1; i < n; i++) {
        int id = ids[i], j = i;
        for (; j > 0 && (rs->runs[ids[j - 1]].n > rs->runs[id].n ||
                         (rs->runs[ids[j - 1]].n == rs->runs[id].n && ids[j - 1] > id));
             j--)
            ids[j] = ids[j - 1];
        ids[j] = id;
    }
}

/* The non-empty runs of rs into ids (*n of them), merged down to fan_in
 * runs; *levels: merges done. */
static int reduce_to_fan_in(wpd_runs *rs, int fan_in, int *ids, int *n, int *levels,
                            wpd_error *err)
{
    while (*n > fan_in) {
        sort_by_length(rs, ids, *n);
        int k = *n - fan_in + 1 < fan_in ? *n - fan_in + 1 : fan_in, into;
        if (merge_level(rs, ids, k, &into, err))
            return -1;
        memmove(ids, ids + k, (size_t)(*n - k) * sizeof *ids);
        *n -= k;
        ids[(*n)++] = into;
        ++*levels;
    }
    return 0;
}

int wpd_run_merge_open(wpd_runs *rs, size_t budget, wpd_run_merge **out, wpd_error *err)
{
    *out = NULL;
    wpd_run_merge *m = calloc(1, sizeof *m);
    int *ids = malloc((size_t)(rs->nruns ? rs->nruns : 1) * sizeof *ids);
    if (!m || !ids) {
        free(m), free(ids);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory to merge %d runs", rs->nruns);
    }
    int n = 0;
    for (int id = 0; id < rs->nruns; id++)
        if (rs->runs[id].n)
            ids[n++] = id;
    int fan_in = rs->in_files ? wpd_run_merge_fan_in(rs->chunk_points, budget) : n;
    int rc = reduce_to_fan_in(rs, fan_in, ids, &n, &m->levels, err);
    if (rc == 0)
        rc = merger_init(&m->m, rs, ids, n, err);
    free(ids);
    if (rc) {
        free(m);
        return -1;
    }
    m->nslots = n;
    *out = m;
    return 0;
}

int wpd_run_merge_next(wpd_run_merge *m, uint64_t end, wpd_sample_view *v, wpd_error *err)
{
    return merger_next(&m->m, end, v, err);
}

uint64_t wpd_run_merge_left(const wpd_run_merge *m) { return m->m.left; }
int wpd_run_merge_levels(const wpd_run_merge *m) { return m->levels; }
size_t wpd_run_merge_chunk_points(const wpd_run_merge *m) { return m->m.rs->chunk_points; }

void wpd_run_merge_close(wpd_run_merge *m)
{
    if (!m)
        return;
    merger_free(&m->m, m->nslots);
    free(m);
}
