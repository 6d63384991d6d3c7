/* records.c - the samples' records, from a last streaming pass over the
 * inputs: the samples are sorted by global index, which is the reading
 * order. Tiles hold coordinates only - the records, half the spilled
 * bytes, are needed for the kept 1 % alone (docs/engine.md has the
 * figures). */
#include "resample/run.h"

#include <stdlib.h>
#include <string.h>

#include "core/sort.h"
#include "resample/budget.h"
#include "resample/pass.h"

typedef struct gather {
    wpd_run *e;
    size_t next;              /* ordered: the first sample not copied yet */
    size_t *copied;           /* [lanes] samples each lane copied */
} gather;

/* Copies the records of the samples from `from` on that lie in the batch
 * (its first point has global index first); returns the next sample. */
static size_t copy_batch(wpd_run *e, const wpd_batch *b, uint64_t first, size_t from)
{
    wpd_resample_result *res = e->res;
    size_t rs = e->record_size, i = from;
    for (; i < res->count && res->gid[i] < first + b->n; i++)
        memcpy(res->records + i * rs, b->records + (res->gid[i] - first) * rs, rs);
    return i;
}

/* The first sample with a global index >= gid. */
static size_t first_sample_from(const wpd_resample_result *res, uint64_t gid)
{
    return wpd_lower_bound_u64(res->gid, res->count, gid);
}

/* Unordered: each lane copies its batches' samples into their own slots
 * (the global indices are known in the lanes, see wpd_records_phase). */
static int copy_lane(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    (void)err;
    gather *g = arg;
    size_t from = first_sample_from(g->e->res, pb->first_gid);
    g->copied[pb->lane] += copy_batch(g->e, pb->batch, pb->first_gid, from) - from;
    return 0;
}

/* Ordered: the commits copy, in reading order, where the global indices
 * are exact. */
static int copy_commit(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    (void)err;
    gather *g = arg;
    size_t from = g->next;
    g->next = copy_batch(g->e, pb->batch, pb->first_gid, from);
    g->copied[pb->lane] += g->next - from;
    return 0;
}

/* The records of the samples. Where no point was dropped, global index =
 * record index: every lane knows the indices of its batches and copies on
 * its own, and the pass stops at the last sample's record. Otherwise the
 * indices are exact only in reading order: the pass is ordered and the
 * commits copy (reading and decoding, the work, still run in parallel). */
int wpd_records_phase(wpd_run *e, wpd_error *err)
{
    wpd_resample_result *res = e->res;
    res->records = malloc((res->count ? res->count : 1) * e->record_size);
    if (!res->records)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu records", res->count);
    if (res->count == 0)
        return 0;
    int every_finite = e->scan.count == wpd_cloud_count(e->cloud);
    int threads = wpd_budget_pass_threads(e->opt->mem_bytes, e->threads,
                                          wpd_budget_samples_bytes(e->opt->target, e->record_size),
                                          wpd_pass_lane_bytes(e->cloud));
    gather g = {e, 0, calloc((size_t)threads, sizeof(size_t))};
    if (!g.copied)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu records", res->count);
    wpd_pass pass = {.cloud = e->cloud, .threads = threads,
                     .end = every_finite ? res->gid[res->count - 1] + 1 : 0,
                     .every_record_finite = every_finite,
                     .lane = every_finite ? copy_lane : NULL,
                     .commit = every_finite ? NULL : copy_commit, .arg = &g,
                     .progress = e->opt->progress};
    int rc = wpd_pass_run(&pass, err);
    size_t copied = 0;
    for (int l = 0; l < threads; l++)
        copied += g.copied[l];
    free(g.copied);
    if (rc == 0 && copied != res->count)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                      wpd_cloud_header(e->cloud, 0)->path);
    return rc;
}
