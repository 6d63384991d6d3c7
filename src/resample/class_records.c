/* class_records.c - the records pass of a run by class (classes.h,
 * wpd_class_stream_records): each input point not dropped is written as
 * it is (a kept class, a group kept whole) or, for a resampled group, when
 * it is that group's next sample. A group's samples carry the index of the
 * point among the group's points (its run read the cloud filtered to the
 * group), so the pass counts each group's points as it reads them and
 * reads the group's runs merged in that order, a chunk at a time. Nothing
 * is held for all output points: this pass is also what the merge pass
 * that built them in memory before did (issue 12). */
#include "resample/classes.h"

#include <stdlib.h>
#include <string.h>

#include "resample/records.h"

#define NCLASSES (WPD_CLASS_MAX + 1)

/* Output points one pick hands out at most. */
#define PICK_POINTS 8192

/* Where one group stands in the pass. */
typedef struct group_cursor {
    wpd_run_merge *merge;     /* its samples (resampled groups), else NULL */
    wpd_sample_view chunk;    /* the current chunk of them */
    size_t at;                /* its next sample */
    uint64_t seen;            /* the group's points read so far */
} group_cursor;

typedef struct class_picker {
    const wpd_cloud *cloud;
    const wpd_class_result *r;
    group_cursor *group;      /* [ngroups] */
    uint64_t *out_count;      /* [NCLASSES] output points per class */
    uint64_t *gid;            /* [PICK_POINTS] one pick */
    double *xyz;
    uint8_t *edge;            /* NULL without labels */
} class_picker;

/* The sample of group g for the group's point of index local, or NULL when
 * that point was not kept. */
static int group_sample(group_cursor *g, uint64_t local, const double **xyz, uint8_t *edge,
                        wpd_error *err)
{
    if (g->at == g->chunk.n) {
        g->at = 0;
        if (wpd_run_merge_next(g->merge, UINT64_MAX, &g->chunk, err))
            return -1;
    }
    *xyz = NULL;
    if (g->at == g->chunk.n || g->chunk.gid[g->at] != local)
        return 0;
    *xyz = g->chunk.xyz + 3 * g->at;
    *edge = g->chunk.edge ? g->chunk.edge[g->at] : 0;
    g->at++;
    return 0;
}

/* Where point i of the batch goes: *xyz its output coordinates (NULL: not
 * written), *edge its label. */
static int place_point(class_picker *p, const wpd_pass_batch *pb, size_t i, long cls,
                       const double **xyz, uint8_t *edge, wpd_error *err)
{
    int gi = p->r->group_of[cls];
    *xyz = pb->batch->xyz + 3 * i;
    *edge = 0;
    if (gi == WPD_GROUP_KEPT)
        return 0;
    group_cursor *g = &p->group[gi];
    uint64_t local = g->seen++;
    if (p->r->groups[gi].whole)
        return 0;
    if (!g->merge) {
        *xyz = NULL; /* counted to 0, or no run */
        return 0;
    }
    return group_sample(g, local, xyz, edge, err);
}

static int pick_classes(void *arg, const wpd_pass_batch *pb, size_t *at, wpd_sample_view *v,
                        wpd_error *err)
{
    class_picker *p = arg;
    const wpd_batch *b = pb->batch;
    const wpd_dim *field = &p->r->output_filter.field;
    const char *path = wpd_cloud_header(p->cloud, pb->file)->path;
    size_t n = 0, i = *at;
    for (; i < b->n && n < PICK_POINTS; i++) {
        long cls = wpd_class_checked(field, b->records + i * b->record_size, path, err);
        const double *xyz;
        uint8_t edge;
        if (cls < 0 || place_point(p, pb, i, cls, &xyz, &edge, err))
            return -1;
        if (!xyz)
            continue;
        p->gid[n] = pb->first_gid + i;
        memcpy(p->xyz + 3 * n, xyz, 3 * sizeof *xyz);
        if (p->edge)
            p->edge[n] = edge;
        p->out_count[cls]++;
        n++;
    }
    *at = i;
    *v = (wpd_sample_view){n, p->gid, p->xyz, p->edge};
    return 0;
}

static void picker_free(class_picker *p, int ngroups)
{
    for (int i = 0; p->group && i < ngroups; i++)
        wpd_run_merge_close(p->group[i].merge);
    free(p->group);
    free(p->out_count);
    free(p->gid);
    free(p->xyz);
    free(p->edge);
}

/* The picker, with a merge over each resampled group's runs. */
static int picker_init(class_picker *p, wpd_cloud *cloud, const wpd_class_result *r,
                       wpd_error *err)
{
    int resampled = 0, labelled = 0; /* (r->merged may have moved to the caller) */
    for (int i = 0; i < r->ngroups; i++) {
        resampled += r->groups[i].run.samples != NULL && !r->groups[i].whole;
        labelled |= r->groups[i].run.labelled;
    }
    size_t ngroups = r->ngroups > 0 ? (size_t)r->ngroups : 1; /* (never negative) */
    *p = (class_picker){cloud, r, calloc(ngroups, sizeof *p->group),
                        calloc(NCLASSES, sizeof *p->out_count),
                        malloc(PICK_POINTS * sizeof *p->gid),
                        malloc(3 * PICK_POINTS * sizeof *p->xyz),
                        labelled ? malloc(PICK_POINTS) : NULL};
    if (!p->group || !p->out_count || !p->gid || !p->xyz || (labelled && !p->edge))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the records pass");
    size_t budget = WPD_RUN_MERGE_BUDGET / (size_t)(resampled ? resampled : 1);
    for (int i = 0; i < r->ngroups; i++) {
        wpd_runs *samples = r->groups[i].run.samples;
        if (samples && !r->groups[i].whole &&
            wpd_run_merge_open(samples, budget, &p->group[i].merge, err))
            return -1;
    }
    return 0;
}

/* After the pass: every group's samples met their points. */
static int all_samples_written(const class_picker *p, const wpd_cloud *cloud, wpd_error *err)
{
    for (int i = 0; i < p->r->ngroups; i++) {
        const group_cursor *g = &p->group[i];
        if (g->merge && (g->at < g->chunk.n || wpd_run_merge_left(g->merge)))
            return wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                            wpd_cloud_header(cloud, 0)->path);
    }
    return 0;
}

int wpd_class_stream_records(wpd_cloud *cloud, wpd_class_result *r, size_t mem_bytes,
                             int threads, wpd_progress *progress, wpd_sample_sink sink,
                             void *arg, wpd_error *err)
{
    class_picker p;
    int rc = picker_init(&p, cloud, r, err);
    if (rc == 0) {
        size_t held = WPD_RUN_MERGE_BUDGET + NCLASSES * sizeof *p.out_count +
                      PICK_POINTS * WPD_RUNS_SAMPLE_BYTES;
        wpd_cloud_set_filter(cloud, &r->output_filter);
        rc = wpd_records_pass(cloud, pick_classes, &p, held, mem_bytes, threads, progress,
                              sink, arg, err);
        wpd_cloud_set_filter(cloud, NULL);
    }
    if (rc == 0)
        rc = all_samples_written(&p, cloud, err);
    for (int i = 0; rc == 0 && i < r->nlines; i++)
        r->lines[i].out = p.out_count[r->lines[i].cls];
    picker_free(&p, r->ngroups);
    return rc;
}
