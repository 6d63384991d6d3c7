/* merge.c - the samples of all tiles as the result's sorted runs (one per
 * tile, absolute coordinates), with the per-file counts and boxes the
 * output needs before its first record. The runs are merged into
 * global-index order (the output order, whatever the tiling and the
 * threads) only while the records are written (records.c), so no array
 * of all samples is ever built; a cloud resampled in memory keeps its
 * runs in memory (its samples are there anyway), a tiled run reads each
 * tile from the sample store and writes it to files of its own (the
 * store and the spill are removed when the driver returns). */
#include "resample/merge.h"
#include "resample/run.h"
#include "resample/sample_store.h"

#include <stdlib.h>
#include <string.h>

/* Tile samples s in absolute coordinates, counted into the result's
 * per-file counts and boxes (file ends: the first gid past each file). */
static void account_tile(wpd_run *run, wpd_tile_samples *s, const uint64_t *file_end)
{
    wpd_resample_result *res = run->res;
    int f = 0;
    for (size_t i = 0; i < s->n; i++) {
        double *p = s->xyz + 3 * i;
        for (int a = 0; a < 3; a++)
            p[a] += run->scan.origin[a];
        while (f < res->nfiles - 1 && s->gid[i] >= file_end[f])
            f++;
        res->file_samples[f]++;
        wpd_bounds_add(&res->file_bounds[f], p, 1);
        res->sharp_samples += s->edge && s->edge[i];
    }
}

static int open_result_runs(wpd_run *run, uint64_t **file_end, wpd_error *err)
{
    wpd_resample_result *res = run->res;
    size_t nf = (size_t)res->nfiles;
    res->file_samples = calloc(nf ? nf : 1, sizeof *res->file_samples);
    res->file_bounds = malloc((nf ? nf : 1) * sizeof *res->file_bounds);
    *file_end = malloc((nf ? nf : 1) * sizeof **file_end);
    if (!res->file_samples || !res->file_bounds || !*file_end)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (size_t f = 0; f < nf; f++) {
        wpd_bounds_reset(&res->file_bounds[f]);
        (*file_end)[f] = (f ? (*file_end)[f - 1] : 0) + res->file_count[f];
    }
    res->labelled = wpd_store_labelled(run);
    wpd_runs_options o = {res->in_memory ? NULL : run->opt->tmpdir, res->labelled, 0, 0};
    if (wpd_runs_open(&o, &res->samples, err) ||
        wpd_runs_reserve(res->samples, run->plan.ntiles, err))
        return -1;
    return 0;
}

int wpd_merge_phase(wpd_run *run, wpd_error *err)
{
    wpd_resample_result *res = run->res;
    uint64_t *file_end = NULL;
    int rc = open_result_runs(run, &file_end, err);
    for (int t = 0; rc == 0 && t < run->plan.ntiles; t++) {
        if (wpd_store_load(run, t, err)) {
            rc = -1;
            break;
        }
        wpd_tile_samples *s = &run->store[t];
        account_tile(run, s, file_end);
        res->count += s->n;
        /* The run takes the arrays, on failure too. */
        rc = wpd_runs_put(res->samples, t, s->gid, s->xyz, s->edge, s->n, err);
        memset(s, 0, sizeof *s);
    }
    free(file_end);
    return rc;
}
