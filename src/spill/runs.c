/* runs.c - sets of sorted runs (runs.h): the set, memory runs, whole and
 * sequential reads; file chunks are runs_file.c. */
#include "spill/runs_impl.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/tmpdir.h"

int wpd_runs_open(const wpd_runs_options *o, wpd_runs **out, wpd_error *err)
{
    wpd_runs *rs = calloc(1, sizeof *rs);
    *out = NULL;
    if (!rs)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for a run set");
    rs->in_files = o->dir != NULL;
    rs->with_edge = o->with_edge != 0;
    rs->chunk_points = o->chunk_points ? o->chunk_points : WPD_RUNS_CHUNK_POINTS;
    rs->level = o->level ? o->level : -3;
    if (rs->in_files && wpd_tmpdir_create(o->dir, "wpd-runs", rs->dir, sizeof rs->dir, err)) {
        free(rs);
        return -1;
    }
    *out = rs;
    return 0;
}

void wpd_runs_close(wpd_runs *rs)
{
    if (!rs)
        return;
    for (int id = 0; id < rs->nruns; id++)
        wpd_runs_clear(rs, id);
    free(rs->runs);
    runs_encoder_free(&rs->encoder);
    if (rs->in_files)
        wpd_tmpdir_remove(rs->dir);
    free(rs);
}

int wpd_runs_count(const wpd_runs *rs) { return rs->nruns; }
uint64_t wpd_runs_length(const wpd_runs *rs, int id) { return rs->runs[id].n; }
int wpd_runs_in_files(const wpd_runs *rs) { return rs->in_files; }
int wpd_runs_with_edge(const wpd_runs *rs) { return rs->with_edge; }
size_t wpd_runs_chunk_points(const wpd_runs *rs) { return rs->chunk_points; }

size_t wpd_runs_memory_bytes(const wpd_runs *rs)
{
    size_t bytes = (size_t)rs->cap * sizeof *rs->runs;
    for (int id = 0; id < rs->nruns; id++) {
        const run *r = &rs->runs[id];
        bytes += r->cap * (sizeof *r->gid + 3 * sizeof *r->xyz + (r->edge ? 1 : 0));
        bytes += r->chunks_cap * sizeof *r->chunks;
    }
    return bytes;
}

uint64_t wpd_runs_disk_bytes(const wpd_runs *rs)
{
    uint64_t bytes = 0;
    for (int id = 0; id < rs->nruns; id++)
        bytes += rs->runs[id].bytes;
    return bytes;
}

int wpd_runs_reserve(wpd_runs *rs, int n, wpd_error *err)
{
    if (n > rs->cap) {
        int cap = rs->cap ? rs->cap : 16;
        while (cap < n)
            cap *= 2;
        run *grown = realloc(rs->runs, (size_t)cap * sizeof *grown);
        if (!grown)
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for %d runs", n);
        rs->runs = grown;
        rs->cap = cap;
    }
    for (; rs->nruns < n; rs->nruns++)
        memset(&rs->runs[rs->nruns], 0, sizeof *rs->runs);
    return 0;
}

int wpd_runs_add(wpd_runs *rs, int *id, wpd_error *err)
{
    *id = rs->nruns;
    return wpd_runs_reserve(rs, rs->nruns + 1, err);
}

void wpd_runs_clear(wpd_runs *rs, int id)
{
    run *r = &rs->runs[id];
    if (rs->in_files && r->nchunks) {
        char path[1100];
        runs_file_path(rs, id, path, sizeof path);
        unlink(path);
    }
    free(r->gid);
    free(r->xyz);
    free(r->edge);
    free(r->chunks);
    memset(r, 0, sizeof *r);
}

/* Whether v's gids ascend strictly and above the run's last. */
static int ascending(const run *r, const wpd_sample_view *v)
{
    if (v->n && r->n && v->gid[0] <= r->last)
        return 0;
    for (size_t i = 1; i < v->n; i++)
        if (v->gid[i] <= v->gid[i - 1])
            return 0;
    return 1;
}

/* Room for n more samples in memory run r. */
static int memory_room(const wpd_runs *rs, run *r, size_t n)
{
    size_t need = (size_t)r->n + n;
    if (need <= r->cap)
        return 0;
    size_t cap = r->cap ? r->cap : 1024;
    while (cap < need)
        cap *= 2;
    uint64_t *gid = realloc(r->gid, cap * sizeof *gid);
    if (gid)
        r->gid = gid;
    double *xyz = realloc(r->xyz, 3 * cap * sizeof *xyz);
    if (xyz)
        r->xyz = xyz;
    uint8_t *edge = rs->with_edge ? realloc(r->edge, cap) : NULL;
    if (edge) {
        size_t from = r->edge ? r->cap : 0; /* a run taken without labels had none */
        memset(edge + from, 0, cap - from);
        r->edge = edge;
    }
    if (!gid || !xyz || (rs->with_edge && !edge))
        return -1;
    r->cap = cap;
    return 0;
}

static void memory_append(const wpd_runs *rs, run *r, const wpd_sample_view *v)
{
    memcpy(r->gid + r->n, v->gid, v->n * sizeof *v->gid);
    memcpy(r->xyz + 3 * r->n, v->xyz, 3 * v->n * sizeof *v->xyz);
    if (rs->with_edge && v->edge)
        for (size_t i = 0; i < v->n; i++)
            r->edge[r->n + i] = v->edge[i] != 0;
}

int wpd_runs_append(wpd_runs *rs, int id, const wpd_sample_view *v, wpd_error *err)
{
    run *r = &rs->runs[id];
    if (!ascending(r, v))
        return wpd_fail(err, WPD_E_INPUT, "run %d: samples out of order (internal error)", id);
    if (v->n == 0)
        return 0;
    if (rs->in_files) {
        if (runs_file_append(rs, id, v, err))
            return -1;
    } else {
        if (memory_room(rs, r, v->n))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for a run of %llu samples",
                            (unsigned long long)(r->n + v->n));
        memory_append(rs, r, v);
    }
    r->n += v->n;
    r->last = v->gid[v->n - 1];
    return 0;
}

int wpd_runs_put(wpd_runs *rs, int id, uint64_t *gid, double *xyz, uint8_t *edge, size_t n,
                 wpd_error *err)
{
    wpd_runs_clear(rs, id);
    wpd_sample_view v = {n, gid, xyz, edge};
    int rc = 0;
    if (rs->in_files || !ascending(&rs->runs[id], &v)) {
        rc = wpd_runs_append(rs, id, &v, err);
        free(gid), free(xyz), free(edge);
        if (rc)
            wpd_runs_clear(rs, id);
        return rc;
    }
    run *r = &rs->runs[id];
    if (!rs->with_edge)
        free(edge), edge = NULL;
    for (size_t i = 0; edge && i < n; i++)
        edge[i] = edge[i] != 0;
    *r = (run){.n = n, .last = n ? gid[n - 1] : 0, .gid = gid, .xyz = xyz, .edge = edge,
               .cap = n};
    return 0;
}

/* ------------------------------------------------------ sequential reading */

void wpd_run_reader_open(wpd_run_reader *r, const wpd_runs *rs, int id)
{
    memset(r, 0, sizeof *r);
    r->rs = rs;
    r->id = id;
    r->fd = -1;
}

void wpd_run_reader_close(wpd_run_reader *r)
{
    if (r->fd >= 0)
        close(r->fd);
    free(r->gid);
    free(r->xyz);
    free(r->edge);
    memset(r, 0, sizeof *r);
    r->fd = -1;
}

/* The next chunk of a file run, decoded into the reader's buffer. */
static int next_file_chunk(wpd_run_reader *r, wpd_run_decoder *d, wpd_sample_view *v,
                           wpd_error *err)
{
    const wpd_runs *rs = r->rs;
    size_t cap = rs->chunk_points;
    if (!r->gid) {
        r->gid = malloc(cap * sizeof *r->gid);
        r->xyz = malloc(3 * cap * sizeof *r->xyz);
        r->edge = rs->with_edge ? malloc(cap) : NULL;
        if (!r->gid || !r->xyz || (rs->with_edge && !r->edge))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory to read a run");
    }
    if (r->fd < 0 && (r->fd = runs_file_open(rs, r->id, err)) < 0)
        return -1;
    uint32_t c = r->chunk++;
    if (runs_file_read_chunk(rs, r->id, r->fd, c, d, r->gid, r->xyz, r->edge, err))
        return -1;
    *v = (wpd_sample_view){rs->runs[r->id].chunks[c].count, r->gid, r->xyz, r->edge};
    /* Closed after the last chunk, and checked: storage that loses data
     * may say so at any close (as the spill's reads do). */
    if (r->chunk == rs->runs[r->id].nchunks) {
        int fd = r->fd;
        r->fd = -1;
        if (close(fd)) {
            char path[1100];
            runs_file_path(rs, r->id, path, sizeof path);
            return wpd_fail_errno(err, "%s: cannot close run file", path);
        }
    }
    return 0;
}

int wpd_run_reader_next(wpd_run_reader *r, wpd_run_decoder *d, wpd_sample_view *v,
                        wpd_error *err)
{
    const run *run = &r->rs->runs[r->id];
    memset(v, 0, sizeof *v);
    if (r->done >= run->n)
        return 0;
    if (r->rs->in_files) {
        if (next_file_chunk(r, d, v, err))
            return -1;
    } else {
        size_t at = (size_t)r->done, left = (size_t)(run->n - r->done);
        size_t m = left < r->rs->chunk_points ? left : r->rs->chunk_points;
        *v = (wpd_sample_view){m, run->gid + at, run->xyz + 3 * at,
                               run->edge ? run->edge + at : NULL};
    }
    r->done += v->n;
    return 0;
}

int wpd_runs_read(const wpd_runs *rs, int id, uint64_t **gid, double **xyz, uint8_t **edge,
                  size_t *n, wpd_error *err)
{
    size_t len = (size_t)rs->runs[id].n, m = len ? len : 1;
    *gid = malloc(m * sizeof **gid);
    *xyz = malloc(3 * m * sizeof **xyz);
    *edge = rs->with_edge ? calloc(m, 1) : NULL;
    wpd_run_decoder *d = rs->in_files ? wpd_run_decoder_new(rs) : NULL;
    int rc = *gid && *xyz && (*edge || !rs->with_edge) && (d || !rs->in_files)
                 ? 0
                 : wpd_fail(err, WPD_E_MEMORY, "out of memory to read a run of %zu samples",
                            len);
    wpd_run_reader r;
    wpd_run_reader_open(&r, rs, id);
    size_t at = 0;
    for (wpd_sample_view v = {0}; rc == 0; at += v.n) {
        if ((rc = wpd_run_reader_next(&r, d, &v, err)) || v.n == 0)
            break;
        memcpy(*gid + at, v.gid, v.n * sizeof *v.gid);
        memcpy(*xyz + 3 * at, v.xyz, 3 * v.n * sizeof *v.xyz);
        if (*edge && v.edge)
            memcpy(*edge + at, v.edge, v.n);
    }
    wpd_run_reader_close(&r);
    wpd_run_decoder_free(d);
    if (rc) {
        free(*gid), free(*xyz), free(*edge);
        *gid = NULL, *xyz = NULL, *edge = NULL;
    }
    *n = rc ? 0 : len;
    return rc;
}
