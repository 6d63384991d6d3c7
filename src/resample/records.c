/* records.c - the samples' records, from a last streaming pass over the
 * inputs: the samples are sorted by global index, which is the reading
 * order. Tiles hold coordinates only - the records, half the spilled
 * bytes, are needed for the kept 1 % alone (docs/engine.md has the
 * figures). */
#include "resample/run.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "resample/budget.h"

/* Copies the records of samples [lo, hi) (sorted by global index) from
 * cloud, which delivers the points from global index `first` on. */
static int copy_records(wpd_run *e, wpd_cloud *cloud, size_t lo, size_t hi, uint64_t first,
                        wpd_error *err)
{
    wpd_resample_result *res = e->res;
    size_t rs = e->record_size;
    wpd_batch b;
    if (wpd_batch_init(&b, WPD_BATCH_POINTS, e->record_size))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu records", res->count);
    size_t next = lo;
    long got = 0;
    while (next < hi && (got = wpd_cloud_read(cloud, &b, NULL, err)) > 0) {
        for (; next < hi && res->gid[next] < first + b.n; next++)
            memcpy(res->records + next * rs, b.records + (res->gid[next] - first) * rs, rs);
        first += b.n;
        wpd_progress_add(e->opt->progress, b.n);
    }
    wpd_batch_free(&b);
    if (next < hi)
        return got < 0 ? -1
                       : wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                                  wpd_cloud_header(cloud, 0)->path);
    return 0;
}

/* Each thread reads the stretch of the inputs that holds its share of the
 * samples, with a cloud of its own positioned there: possible when every
 * record is a point (global index = record index) and the format can
 * seek. Returns 0, -1 with err set, or 1 when it cannot (nothing done). */
static int gather_records_parallel(wpd_run *e, wpd_error *err)
{
    wpd_resample_result *res = e->res;
    size_t batch_bytes = wpd_budget_batch_bytes(e->record_size);
    int threads = wpd_budget_pass_threads(e->opt->mem_bytes, e->threads,
                                          wpd_budget_samples_bytes(e->opt->target, e->record_size),
                                          batch_bytes);
    if (threads < 2 || res->count < 2 || e->scan.count != wpd_cloud_count(e->cloud))
        return 1;
    _Atomic int unseekable = 0;
    wpd_first_error fe = {0};
#pragma omp parallel num_threads(threads)
    {
        int t = omp_get_thread_num(), nt = omp_get_num_threads();
        size_t lo = res->count * (size_t)t / (size_t)nt;
        size_t hi = res->count * (size_t)(t + 1) / (size_t)nt;
        wpd_error mine = {0};
        wpd_cloud *c = lo < hi ? wpd_cloud_reopen(e->cloud, &mine) : NULL;
        int rc = lo < hi ? (c ? 0 : -1) : 0;
        if (rc == 0 && c && wpd_cloud_seek(c, res->gid[lo], &mine))
            rc = mine.code == WPD_E_USAGE ? 1 : -1;
        if (rc == 0 && c)
            rc = copy_records(e, c, lo, hi, res->gid[lo], &mine);
        wpd_cloud_close(c);
        if (rc == 1)
            unseekable = 1;
        else if (rc)
            wpd_first_error_keep(&fe, &mine);
    }
    if (wpd_first_error_take(&fe, err))
        return -1;
    return unseekable ? 1 : 0;
}

/* The records of the samples, from a last streaming pass over the inputs:
 * the samples are sorted by global index, which is the reading order. The
 * tiles hold coordinates only - the records, half the spilled bytes, are
 * needed for the kept 1 % alone (docs/engine.md has the figures). */
int wpd_records_phase(wpd_run *e, wpd_error *err)
{
    wpd_resample_result *res = e->res;
    res->records = malloc((res->count ? res->count : 1) * e->record_size);
    if (!res->records)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu records", res->count);
    int rc = gather_records_parallel(e, err);
    if (rc != 1)
        return rc;
    if (wpd_cloud_rewind(e->cloud, err))
        return -1;
    return copy_records(e, e->cloud, 0, res->count, 0, err);
}

