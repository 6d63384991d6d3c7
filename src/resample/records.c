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

int wpd_records_pass(wpd_cloud *cloud, wpd_records_picker pick, void *pick_arg, size_t in_use,
                     size_t mem_bytes, int threads, wpd_progress *progress, wpd_sample_sink sink,
                     void *arg, wpd_error *err)
{
    const wpd_header *h = wpd_cloud_header(cloud, 0);
    stream s = {pick, pick_arg, NULL, 0, sink, arg, h->path};
    /* Reading and decoding run on the lanes, the picks, copies and the sink
     * in the ordered commits (where the global indices are exact). */
    int lanes = wpd_budget_pass_threads(mem_bytes, threads > 0 ? threads : 1, in_use,
                                        wpd_pass_lane_bytes(cloud));
    wpd_pass pass = {.cloud = cloud, .threads = lanes, .commit = stream_commit, .arg = &s,
                     .progress = progress};
    wpd_test_stall("records");
    int rc = wpd_cloud_rewind(cloud, err) ? -1 : wpd_pass_run(&pass, err);
    free(s.buf);
    return rc;
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
