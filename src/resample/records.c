/* records.c - the samples' records on their way out: one ordered
 * streaming pass over the inputs hands each batch's output points, with
 * their input records, to a sink in global-index order (resample.h,
 * records.h). The records are never held for all samples: tiles hold
 * coordinates only, and the records - half the spilled bytes - are needed
 * for the kept points alone (docs/engine.md has the figures); here each is
 * copied once from the batch it is read in to the sink, which writes it.
 * The samples themselves come from the merge of the result's runs, one
 * chunk at a time. */
#include "resample/records.h"

#include <stdlib.h>
#include <string.h>

#include "resample/budget.h"
#include "common/testhook.h"

typedef struct stream {
    wpd_records_picker pick;
    void *pick_arg;
    uint8_t *buf;             /* the records of one pick */
    size_t cap;               /* bytes of buf */
    wpd_sample_sink sink;
    void *arg;
    const char *path;         /* the first input, for errors */
} stream;

/* Room for n records of rs bytes in s->buf. */
static int room_for(stream *s, size_t n, size_t rs)
{
    if (n * rs <= s->cap)
        return 0;
    uint8_t *grown = realloc(s->buf, n * rs);
    if (!grown)
        return -1;
    s->buf = grown;
    s->cap = n * rs;
    return 0;
}

/* In reading order: the batch's output points (global indices first_gid ..
 * first_gid + n - 1) go to the sink with their records. */
static int stream_commit(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    stream *s = arg;
    const wpd_batch *b = pb->batch;
    size_t rs = b->record_size;
    uint64_t first = pb->first_gid;
    for (size_t at = 0; at < b->n;) {
        wpd_sample_view v;
        if (s->pick(s->pick_arg, pb, &at, &v, err))
            return -1;
        if (v.n == 0)
            continue;
        if (v.gid[0] < first || v.gid[v.n - 1] - first >= b->n)
            return wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                            s->path);
        if (room_for(s, v.n, rs))
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu records", v.n);
        for (size_t k = 0; k < v.n; k++)
            memcpy(s->buf + k * rs, b->records + (v.gid[k] - first) * rs, rs);
        if (s->sink(s->arg, pb->file, v.xyz, v.edge, s->buf, v.n, err))
            return -1;
    }
    return 0;
}

/* The pass over pass->cloud with the stream's commits (pass->commit may
 * wrap stream_commit): lanes within the budget. */
static int run_stream(wpd_pass *pass, stream *s, size_t in_use, size_t mem_bytes, int threads,
                      wpd_error *err)
{
    /* Reading and decoding run on the lanes, the picks, copies and the sink
     * in the ordered commits (where the global indices are exact). */
    pass->threads = wpd_budget_pass_threads(mem_bytes, threads > 0 ? threads : 1, in_use,
                                            wpd_pass_lane_bytes(pass->cloud));
    if (!pass->commit)
        pass->commit = stream_commit;
    if (!pass->arg)
        pass->arg = s;
    wpd_test_stall("records");
    int rc = wpd_cloud_rewind(pass->cloud, err) ? -1 : wpd_pass_run(pass, err);
    free(s->buf);
    return rc;
}

int wpd_records_pass(wpd_cloud *cloud, wpd_records_picker pick, void *pick_arg, size_t in_use,
                     size_t mem_bytes, int threads, wpd_progress *progress, wpd_sample_sink sink,
                     void *arg, wpd_error *err)
{
    stream s = {pick, pick_arg, NULL, 0, sink, arg, wpd_cloud_header(cloud, 0)->path};
    wpd_pass pass = {.cloud = cloud, .progress = progress};
    return run_stream(&pass, &s, in_use, mem_bytes, threads, err);
}

/* The picker over a merge of a run's samples: those below the batch's end,
 * a chunk at a time. */
static int pick_samples(void *arg, const wpd_pass_batch *pb, size_t *at, wpd_sample_view *v,
                        wpd_error *err)
{
    wpd_run_merge *m = arg;
    uint64_t first = pb->first_gid, end = first + pb->batch->n;
    if (wpd_run_merge_next(m, end, v, err))
        return -1;
    /* A chunk cut short means none is left below end. */
    int full = v->n && v->n == wpd_run_merge_chunk_points(m);
    *at = full && v->gid[v->n - 1] >= first ? (size_t)(v->gid[v->n - 1] - first + 1)
                                            : pb->batch->n;
    return 0;
}

int wpd_resample_stream_records(wpd_cloud *cloud, wpd_run_merge *samples, size_t mem_bytes,
                                int threads, wpd_progress *progress, wpd_sample_sink sink,
                                void *arg, wpd_error *err)
{
    int rc = wpd_records_pass(cloud, pick_samples, samples, WPD_RUN_MERGE_BUDGET, mem_bytes,
                              threads, progress, sink, arg, err);
    if (rc == 0 && wpd_run_merge_left(samples))
        rc = wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                      wpd_cloud_header(cloud, 0)->path);
    return rc;
}

/* ---- one rank's share: samples [first, first + count) ---- */

/* The picker over the samples of a share: the merge's, after the skipped
 * ones; held: the rest of the chunk the skip ended in. */
typedef struct share_pick {
    wpd_run_merge *m;
    wpd_sample_view held;
    uint64_t left;            /* samples still to hand out */
    stream *s;
} share_pick;

/* The first k samples of *v into *out, v moved past them. */
static void take_front(wpd_sample_view *v, size_t k, wpd_sample_view *out)
{
    *out = *v;
    out->n = k;
    v->gid += k;
    v->xyz += 3 * k;
    if (v->edge)
        v->edge += k;
    v->n -= k;
}

static int pick_share(void *arg, const wpd_pass_batch *pb, size_t *at, wpd_sample_view *v,
                      wpd_error *err)
{
    share_pick *sp = arg;
    uint64_t first = pb->first_gid, end = first + pb->batch->n;
    if (sp->held.n) {
        size_t k = 0;
        while (k < sp->held.n && k < sp->left && sp->held.gid[k] < end)
            k++;
        take_front(&sp->held, k, v);
        sp->left -= k;
        *at = sp->held.n || !k || !sp->left ? pb->batch->n : (size_t)(v->gid[k - 1] - first + 1);
        return 0;
    }
    if (!sp->left) {
        v->n = 0;
        *at = pb->batch->n;
        return 0;
    }
    if (wpd_run_merge_next(sp->m, end, v, err))
        return -1;
    int full = v->n && v->n == wpd_run_merge_chunk_points(sp->m);
    if (v->n > sp->left) { /* the share ends inside this chunk */
        v->n = (size_t)sp->left;
        full = 0;
    }
    sp->left -= v->n;
    *at = full && v->gid[v->n - 1] >= first ? (size_t)(v->gid[v->n - 1] - first + 1)
                                            : pb->batch->n;
    return 0;
}

/* The share's commits: the pass ends once every sample of it is out. */
static int share_commit(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    share_pick *sp = arg;
    if (stream_commit(sp->s, pb, err))
        return -1;
    return sp->left == 0 ? 1 : 0;
}

/* Skips the first `skip` samples of the merge; the chunk the skip ends in
 * stays in sp->held. */
static int skip_samples(share_pick *sp, uint64_t skip, wpd_error *err)
{
    while (skip || !sp->held.n) { /* and one chunk more when it ends at a chunk's end */
        wpd_sample_view v;
        if (wpd_run_merge_next(sp->m, UINT64_MAX, &v, err))
            return -1;
        if (!v.n)
            return 1;
        size_t k = v.n < skip ? v.n : (size_t)skip; /* skip 0: none */
        wpd_sample_view dropped;
        take_front(&v, k, &dropped);
        skip -= k;
        sp->held = v;
    }
    return 0;
}

/* The unit whose finite points hold global index gid (unit_points: the
 * points of each of the n units); *unit_gid: the global index of its first. */
static int unit_of(const uint64_t *unit_points, uint64_t n, uint64_t gid, uint64_t *unit,
                   uint64_t *unit_gid)
{
    uint64_t at = 0;
    for (uint64_t u = 0; u < n; u++) {
        if (gid < at + unit_points[u]) {
            *unit = u;
            *unit_gid = at;
            return 0;
        }
        at += unit_points[u];
    }
    return -1;
}

int wpd_resample_stream_share(wpd_cloud *cloud, wpd_run_merge *samples, uint64_t first,
                              uint64_t count, const uint64_t *unit_points, uint64_t nunits,
                              size_t mem_bytes, int threads, wpd_progress *progress,
                              wpd_sample_sink sink, void *arg, wpd_error *err)
{
    const char *path = wpd_cloud_header(cloud, 0)->path;
    if (!count)
        return 0;
    stream s = {pick_share, NULL, NULL, 0, sink, arg, path};
    share_pick sp = {samples, {0}, count, &s};
    s.pick_arg = &sp;
    int rc = skip_samples(&sp, first, err);
    uint64_t unit, unit_gid;
    if (rc == 0 && (!sp.held.n || unit_of(unit_points, nunits, sp.held.gid[0], &unit,
                                          &unit_gid)))
        rc = 1; /* fewer samples than the share, or past the units */
    if (rc)
        return rc < 0 ? -1
                      : wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being "
                                 "resampled", path);
    wpd_pass pass = {.cloud = cloud, .progress = progress, .commit = share_commit, .arg = &sp,
                     .first_unit = unit, .first_gid = unit_gid};
    rc = run_stream(&pass, &s, WPD_RUN_MERGE_BUDGET, mem_bytes, threads, err);
    if (rc == 0 && sp.left)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled", path);
    return rc;
}
