/* records.c - the samples' records on their way out: one ordered
 * streaming pass over the inputs hands each batch's samples, with their
 * input records, to a sink in global-index order (resample.h). The records
 * are never held for all samples: tiles hold coordinates only, and the
 * records - half the spilled bytes - are needed for the kept points alone
 * (docs/engine.md has the figures); here each is copied once from the
 * batch it is read in to the sink, which writes it. */
#include "resample/resample.h"

#include <stdlib.h>
#include <string.h>

#include "resample/budget.h"
#include "resample/pass.h"

typedef struct stream {
    const wpd_sample_set *set;
    size_t next;              /* the first sample not handed on yet */
    uint8_t *buf;             /* the records of one batch's samples */
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

/* In reading order: the samples that lie in the batch (global indices
 * first_gid .. first_gid + n - 1) go to the sink with their records. */
static int stream_commit(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    stream *s = arg;
    const wpd_sample_set *set = s->set;
    const wpd_batch *b = pb->batch;
    size_t rs = b->record_size, from = s->next, i = from;
    uint64_t first = pb->first_gid, end = first + b->n;
    while (i < set->count && set->gid[i] < end)
        i++;
    if (i == from)
        return 0;
    if (set->gid[from] < first)
        return wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                        s->path);
    if (room_for(s, i - from, rs))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu records", i - from);
    for (size_t k = from; k < i; k++)
        memcpy(s->buf + (k - from) * rs, b->records + (set->gid[k] - first) * rs, rs);
    s->next = i;
    return s->sink(s->arg, pb->file, set->xyz + 3 * from, set->edge ? set->edge + from : NULL,
                   s->buf, i - from, err);
}

int wpd_resample_stream_records(wpd_cloud *cloud, const wpd_sample_set *set, size_t mem_bytes,
                                int threads, wpd_progress *progress, wpd_sample_sink sink,
                                void *arg, wpd_error *err)
{
    const wpd_header *h = wpd_cloud_header(cloud, 0);
    stream s = {set, 0, NULL, 0, sink, arg, h->path};
    /* Reading and decoding run on the lanes, the copies and the sink in the
     * ordered commits (where the global indices are exact). */
    int lanes = wpd_budget_pass_threads(mem_bytes, threads > 0 ? threads : 1,
                                        set->count * (sizeof *set->gid + 3 * sizeof *set->xyz + 1),
                                        wpd_pass_lane_bytes(cloud));
    wpd_pass pass = {.cloud = cloud, .threads = lanes, .commit = stream_commit, .arg = &s,
                     .progress = progress};
    int rc = wpd_cloud_rewind(cloud, err) ? -1 : wpd_pass_run(&pass, err);
    free(s.buf);
    if (rc == 0 && s.next != set->count)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled", h->path);
    return rc;
}
