/* classes.c - resampling by class (classes.h): a histogram pass, one run
 * of the driver per resampled group over the cloud filtered to it, and a
 * merge pass that puts the groups' samples and the kept points back in
 * input order. */
#include "resample/classes.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "resample/budget.h"
#include "resample/pass.h"

#define NCLASSES (WPD_CLASS_MAX + 1)

wpd_class_role wpd_class_role_of(const wpd_class_options *o, long cls)
{
    if (o->drop && o->drop[cls])
        return WPD_CLASS_DROP;
    if (o->keep && o->keep[cls])
        return WPD_CLASS_KEEP;
    for (int i = 0; i < o->ncounts; i++)
        if (o->counts[i].cls == cls)
            return WPD_CLASS_COUNT;
    return WPD_CLASS_REST;
}

/* ------------------------------------------------------------ histogram */

typedef struct histogram {
    const wpd_cloud *cloud;
    const wpd_dim *field;
    uint64_t *lane;           /* [lanes][NCLASSES] */
} histogram;

/* The class of a record of input file `file`, or -1 with err naming it. */
static long class_checked(const wpd_cloud *c, int file, const wpd_dim *f, const uint8_t *rec,
                          wpd_error *err)
{
    return wpd_class_checked(f, rec, wpd_cloud_header(c, file)->path, err);
}

/* Lanes of a pass of this run with per_lane bytes of state each. */
static int pass_lanes(const wpd_resample_options *opt, size_t per_lane)
{
    int want = opt->params.threads > 0 ? opt->params.threads : omp_get_max_threads();
    return wpd_budget_pass_threads(opt->mem_bytes, want, 0, per_lane);
}

/* Bytes one output point takes until it is written: global index,
 * coordinates, sharp label. */
#define OUTPUT_POINT_BYTES (sizeof(uint64_t) + 3 * sizeof(double) + 1)

static int count_lane(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    histogram *h = arg;
    uint64_t *count = h->lane + (size_t)pb->lane * NCLASSES;
    const wpd_batch *b = pb->batch;
    for (size_t i = 0; i < b->n; i++) {
        long cls = class_checked(h->cloud, pb->file, h->field, b->records + i * b->record_size,
                                 err);
        if (cls < 0)
            return -1;
        count[cls]++;
    }
    return 0;
}

/* Finite points per class over the whole cloud into count[NCLASSES]. */
static int class_histogram(wpd_cloud *cloud, const wpd_class_options *o,
                           const wpd_resample_options *opt, uint64_t *count, wpd_error *err)
{
    int threads = pass_lanes(opt, wpd_pass_lane_bytes(cloud) + NCLASSES * sizeof(uint64_t));
    histogram h = {cloud, &o->field, calloc((size_t)threads * NCLASSES, sizeof(uint64_t))};
    if (!h.lane)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the class histogram");
    wpd_pass pass = {.cloud = cloud, .threads = threads, .lane = count_lane, .arg = &h,
                     .progress = opt->progress};
    wpd_progress_phase(opt->progress, "classes", wpd_cloud_count(cloud), "points");
    int rc = wpd_cloud_rewind(cloud, err) || wpd_pass_run(&pass, err) ? -1 : 0;
    wpd_progress_end(opt->progress);
    for (int l = 0; l < threads; l++)
        for (size_t k = 0; k < NCLASSES; k++)
            count[k] += h.lane[(size_t)l * NCLASSES + k];
    free(h.lane);
    return rc;
}

/* --------------------------------------------------------------- groups */

/* The groups: the rest (index 0), then one per counted class. */
static int plan_groups(const wpd_class_options *o, const uint64_t *count, int quiet,
                       wpd_class_result *out, wpd_error *err)
{
    out->ngroups = 1 + o->ncounts;
    out->groups = calloc((size_t)out->ngroups, sizeof *out->groups);
    if (!out->groups)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    wpd_class_group *rest = &out->groups[0];
    rest->cls = -1;
    for (long c = 0; c < NCLASSES; c++) {
        wpd_class_role role = wpd_class_role_of(o, c);
        if (role == WPD_CLASS_REST)
            rest->points += count[c];
        else if (role == WPD_CLASS_DROP)
            out->dropped += count[c];
    }
    rest->target = o->rest_percent >= 0
                       ? (uint64_t)nearbyint(o->rest_percent / 100.0 * (double)rest->points)
                       : o->rest_count;
    rest->whole = rest->target >= rest->points;
    for (int i = 0; i < o->ncounts; i++) {
        wpd_class_group *g = &out->groups[1 + i];
        g->cls = o->counts[i].cls;
        g->points = count[g->cls];
        g->target = o->counts[i].count;
        g->whole = g->target >= g->points;
        if (!quiet && g->whole && g->points)
            fprintf(stderr, "wpd resample: notice: --class-count %ld=%llu: the class has %llu "
                    "points: keeping them all\n", g->cls, (unsigned long long)g->target,
                    (unsigned long long)g->points);
    }
    if (!quiet && rest->whole && rest->points && rest->target > 0)
        fprintf(stderr, "wpd resample: notice: -n %llu >= the %llu points of the classes not "
                "named: keeping them all\n", (unsigned long long)rest->target,
                (unsigned long long)rest->points);
    return 0;
}

/* Notices for the classes named but absent: a cron run over tiles without
 * noise names the noise classes all the same. */
static void notice_absent(const wpd_class_options *o, const uint64_t *count)
{
    for (long c = 0; c < NCLASSES; c++) {
        wpd_class_role role = wpd_class_role_of(o, c);
        if (role != WPD_CLASS_REST && count[c] == 0)
            fprintf(stderr, "wpd resample: notice: no point of class %ld in the input (%s)\n",
                    c, role == WPD_CLASS_DROP ? "--drop-class" : role == WPD_CLASS_KEEP
                                                                      ? "--keep-class"
                                                                      : "--class-count");
    }
}

/* 1 when class c belongs to group g. */
static int in_group(const wpd_class_options *o, const wpd_class_group *g, long c)
{
    return g->cls >= 0 ? c == g->cls : wpd_class_role_of(o, c) == WPD_CLASS_REST;
}

/* Bytes a finished run holds until the merge. */
static size_t held_bytes(const wpd_resample_result *r)
{
    return r->count * OUTPUT_POINT_BYTES;
}

static void add_times(wpd_resample_timings *sum, const wpd_resample_timings *t)
{
    sum->bounds += t->bounds, sum->scan += t->scan, sum->plan += t->plan;
    sum->tile += t->tile, sum->poisson += t->poisson, sum->exact += t->exact;
    sum->smooth += t->smooth, sum->merge += t->merge, sum->total += t->total;
}

/* Refuses, before the runs, an output that does not fit the budget twice
 * over: the groups' samples are held until the merge copies them, with the
 * kept points, into the output (both in memory until the output side is
 * out of core, issue 12). */
static int check_output_fits(const wpd_class_result *out, const uint64_t *count,
                             const wpd_class_options *o, size_t mem, wpd_error *err)
{
    uint64_t n = 0;
    for (long c = 0; c < NCLASSES; c++)
        n += wpd_class_role_of(o, c) == WPD_CLASS_KEEP ? count[c] : 0;
    for (int i = 0; i < out->ngroups; i++) {
        const wpd_class_group *g = &out->groups[i];
        n += g->whole ? g->points : g->target;
    }
    double need = 2.0 * (double)n * (double)OUTPUT_POINT_BYTES;
    if (need > (double)mem)
        return wpd_fail(err, WPD_E_MEMORY, "memory budget too small: the %llu output points "
                        "(kept classes included) need at least %.0f MiB (--mem)",
                        (unsigned long long)n, need / 1048576.0);
    return 0;
}

/* Runs the driver for group g over the cloud filtered to it, in what the
 * budget leaves beside the runs already held. */
static int run_group(wpd_cloud *cloud, const wpd_class_options *o,
                     const wpd_resample_options *opt, size_t held, wpd_class_group *g,
                     uint8_t *accept, wpd_error *err)
{
    for (long c = 0; c < NCLASSES; c++)
        accept[c] = (uint8_t)in_group(o, g, c);
    wpd_point_filter filter = {o->field, accept};
    if (held >= opt->mem_bytes)
        return wpd_fail(err, WPD_E_MEMORY, "memory budget too small: the samples of the "
                        "classes done so far take %zu MiB", held >> 20);
    wpd_resample_options ro = *opt;
    ro.target = g->target;
    ro.mem_bytes = opt->mem_bytes - held;
    wpd_cloud_set_filter(cloud, &filter);
    int rc = wpd_cloud_rewind(cloud, err) ? -1 : wpd_resample_run(cloud, &ro, &g->run, err);
    wpd_cloud_set_filter(cloud, NULL);
    return rc;
}

/* ---------------------------------------------------------------- merge */

typedef struct merger {
    const wpd_class_options *o;
    const wpd_cloud *cloud;
    wpd_class_result *out;
    int8_t *group_of;         /* [NCLASSES]: group index, -1 dropped, -2 kept */
    uint64_t *seen;           /* [ngroups] points of each group read so far */
    size_t *next;             /* [ngroups] the group's next sample */
    uint64_t *out_count;      /* [NCLASSES] points written per class */
} merger;

/* Appends one point (coordinates xyz, sharp label edge) to the merged
 * result as global index gid; its record comes from the records pass. */
static void append(wpd_resample_result *m, uint64_t gid, const double *xyz, uint8_t edge)
{
    size_t k = m->count++;
    m->gid[k] = gid;
    memcpy(m->xyz + 3 * k, xyz, 3 * sizeof *xyz);
    if (m->edge)
        m->edge[k] = edge;
}

/* Whether the point of group gi just read is written, and from where. */
static void merge_point(merger *mg, int gi, uint64_t gid, const double *xyz)
{
    wpd_resample_result *m = &mg->out->merged;
    if (gi == -2) {
        append(m, gid, xyz, 0);
        return;
    }
    wpd_class_group *g = &mg->out->groups[gi];
    uint64_t local = mg->seen[gi]++;
    if (g->whole) {
        append(m, gid, xyz, 0);
        return;
    }
    const wpd_resample_result *r = &g->run;
    size_t s = mg->next[gi];
    if (s < r->count && r->gid[s] == local) {
        append(m, gid, r->xyz + 3 * s, r->edge ? r->edge[s] : 0);
        mg->next[gi] = s + 1;
    }
}

static int merge_commit(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    merger *mg = arg;
    const wpd_batch *b = pb->batch;
    for (size_t i = 0; i < b->n; i++) {
        const uint8_t *rec = b->records + i * b->record_size;
        long cls = class_checked(mg->cloud, pb->file, &mg->o->field, rec, err);
        if (cls < 0)
            return -1;
        size_t before = mg->out->merged.count;
        merge_point(mg, mg->group_of[cls], pb->first_gid + i, b->xyz + 3 * i);
        mg->out_count[cls] += mg->out->merged.count - before;
    }
    return 0;
}

/* Room for every output point; the merged result's facts. */
static int merged_alloc(wpd_class_result *out, const wpd_cloud *cloud, uint64_t kept,
                        int with_edge, wpd_error *err)
{
    wpd_resample_result *m = &out->merged;
    size_t n = (size_t)kept;
    for (int i = 0; i < out->ngroups; i++)
        n += out->groups[i].whole ? out->groups[i].points : out->groups[i].run.count;
    m->record_size = wpd_cloud_header(cloud, 0)->schema.record_size;
    m->nfiles = wpd_cloud_nfiles(cloud);
    size_t alloc = n ? n : 1;
    m->gid = malloc(alloc * sizeof *m->gid);
    m->xyz = malloc(3 * alloc * sizeof *m->xyz);
    m->edge = with_edge ? calloc(alloc, 1) : NULL;
    m->file_count = calloc((size_t)m->nfiles, sizeof *m->file_count);
    if (!m->gid || !m->xyz || (with_edge && !m->edge) || !m->file_count)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the %zu output points", n);
    return 0;
}

/* The group of each class: its index, -1 dropped, -2 kept. */
static void map_groups(const wpd_class_options *o, const wpd_class_result *out, int8_t *group_of)
{
    for (long c = 0; c < NCLASSES; c++) {
        wpd_class_role role = wpd_class_role_of(o, c);
        group_of[c] = role == WPD_CLASS_DROP ? -1 : role == WPD_CLASS_KEEP ? -2 : 0;
        for (int i = 1; role == WPD_CLASS_COUNT && i < out->ngroups; i++)
            if (out->groups[i].cls == c)
                group_of[c] = (int8_t)i;
    }
}

/* The lines of the report: every class present in the input. */
static int class_lines(const wpd_class_options *o, const uint64_t *in, const uint64_t *outc,
                       wpd_class_result *out, wpd_error *err)
{
    int n = 0;
    for (long c = 0; c < NCLASSES; c++)
        n += in[c] > 0;
    out->lines = calloc((size_t)(n ? n : 1), sizeof *out->lines);
    if (!out->lines)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (long c = 0; c < NCLASSES; c++)
        if (in[c])
            out->lines[out->nlines++] = (wpd_class_line){c, wpd_class_role_of(o, c), in[c],
                                                         outc[c]};
    return 0;
}

/* The merge pass: every point not dropped, in input order. */
static int merge_pass(wpd_cloud *cloud, const wpd_class_options *o,
                      const wpd_resample_options *opt, const uint64_t *count,
                      wpd_class_result *out, wpd_error *err)
{
    uint64_t kept = 0;
    uint8_t *accept = out->output_accept = malloc(NCLASSES);
    merger mg = {o, cloud, out, malloc(NCLASSES), calloc((size_t)out->ngroups, sizeof(uint64_t)),
                 calloc((size_t)out->ngroups, sizeof(size_t)),
                 calloc(NCLASSES, sizeof(uint64_t))};
    int rc = -1, with_edge = 0;
    if (!accept || !mg.group_of || !mg.seen || !mg.next || !mg.out_count) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
        goto done;
    }
    map_groups(o, out, mg.group_of);
    for (long c = 0; c < NCLASSES; c++) {
        accept[c] = mg.group_of[c] != -1;
        kept += mg.group_of[c] == -2 ? count[c] : 0;
    }
    for (int i = 0; i < out->ngroups; i++)
        with_edge |= out->groups[i].run.edge != NULL;
    if (merged_alloc(out, cloud, kept, with_edge, err))
        goto done;
    out->output_filter = (wpd_point_filter){o->field, accept};
    wpd_cloud_set_filter(cloud, &out->output_filter);
    wpd_pass pass = {.cloud = cloud, .commit = merge_commit, .arg = &mg,
                     .threads = pass_lanes(opt, wpd_pass_lane_bytes(cloud)),
                     .progress = opt->progress};
    wpd_progress_phase(opt->progress, "merge", wpd_cloud_count(cloud), "points");
    rc = wpd_cloud_rewind(cloud, err) || wpd_pass_run(&pass, err) ? -1 : 0;
    wpd_progress_end(opt->progress);
    wpd_cloud_set_filter(cloud, NULL);
    for (int f = 0; rc == 0 && f < out->merged.nfiles; f++)
        out->merged.file_count[f] = wpd_cloud_delivered(cloud, f);
    if (rc == 0)
        rc = class_lines(o, count, mg.out_count, out, err);
done:
    free(mg.group_of);
    free(mg.seen);
    free(mg.next);
    free(mg.out_count);
    return rc;
}

/* Frees r's arrays, keeps its facts. */
static void drop_arrays(wpd_resample_result *r)
{
    free(r->gid), free(r->xyz), free(r->edge);
    free(r->file_count), free(r->tile_box);
    r->gid = NULL, r->xyz = NULL, r->edge = NULL;
    r->file_count = NULL, r->tile_box = NULL;
}

/* The merged result's run facts: the first group run's (its tile boxes
 * move over), times summed. */
static void merged_facts(wpd_class_result *out, const uint64_t *count)
{
    wpd_resample_result *m = &out->merged;
    wpd_resample_result *first = NULL;
    for (long c = 0; c < NCLASSES; c++)
        m->input_points += count[c];
    for (int i = 0; i < out->ngroups; i++) {
        wpd_resample_result *r = &out->groups[i].run;
        if (!out->groups[i].whole && out->groups[i].points) {
            first = first ? first : r;
            m->moved |= r->moved;
            add_times(&m->time, &r->time);
        }
    }
    if (!first)
        return;
    m->radius_estimate = first->radius_estimate, m->radius = first->radius;
    m->first_pass_count = first->first_pass_count, m->poisson_count = first->poisson_count;
    m->passes = first->passes, m->exact_sweeps = first->exact_sweeps;
    m->exact_rounds = first->exact_rounds;
    m->open_cells = first->open_cells, m->pulled_to_surface = first->pulled_to_surface;
    m->non_surface = first->non_surface, m->isolated = first->isolated;
    m->guarded_moves = first->guarded_moves, m->sharp_points = first->sharp_points;
    m->in_memory = first->in_memory, m->tiles = first->tiles, m->colours = first->colours;
    m->largest_tile = first->largest_tile, m->spill = first->spill;
    m->tile_box = first->tile_box; /* moved: the report lists the boxes */
    first->tile_box = NULL;
}

int wpd_resample_by_class(wpd_cloud *cloud, const wpd_class_options *o,
                          const wpd_resample_options *opt, int quiet, wpd_class_result *out,
                          wpd_error *err)
{
    memset(out, 0, sizeof *out);
    uint64_t *count = calloc(NCLASSES, sizeof *count);
    uint8_t *accept = malloc(NCLASSES);
    int rc = -1;
    double t = omp_get_wtime();
    if (!count || !accept) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
        goto done;
    }
    if (class_histogram(cloud, o, opt, count, err) || plan_groups(o, count, quiet, out, err) ||
        check_output_fits(out, count, o, opt->mem_bytes, err))
        goto done;
    if (!quiet)
        notice_absent(o, count);
    out->histogram_seconds = omp_get_wtime() - t;
    size_t held = 0;
    for (int i = 0; i < out->ngroups; i++) {
        wpd_class_group *g = &out->groups[i];
        if (g->whole || g->points == 0 || g->target == 0)
            continue;
        if (run_group(cloud, o, opt, held, g, accept, err))
            goto done;
        held += held_bytes(&g->run);
    }
    t = omp_get_wtime();
    if (merge_pass(cloud, o, opt, count, out, err))
        goto done;
    out->merge_seconds = omp_get_wtime() - t;
    merged_facts(out, count);
    for (int i = 0; i < out->ngroups; i++) /* merged: only the facts are needed */
        drop_arrays(&out->groups[i].run);
    rc = out->merged.count ? 0 : wpd_fail(err, WPD_E_INPUT, "%s: no point left to write "
                                          "(every class dropped or counted to 0)",
                                          wpd_cloud_header(cloud, 0)->path);
done:
    free(count);
    free(accept);
    if (rc)
        wpd_class_result_free(out);
    return rc;
}

void wpd_class_result_free(wpd_class_result *r)
{
    wpd_resample_result_free(&r->merged);
    for (int i = 0; r->groups && i < r->ngroups; i++)
        wpd_resample_result_free(&r->groups[i].run);
    free(r->groups);
    free(r->lines);
    free(r->output_accept);
    memset(r, 0, sizeof *r);
}
