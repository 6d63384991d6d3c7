/* classes.c - resampling by class (classes.h): a histogram pass (points
 * per class, and per file the count and box of each group and of the kept
 * classes), one run of the driver per resampled group over the cloud
 * filtered to it, and the output's facts from those; the groups' samples
 * and the kept points meet in input order only in the records pass
 * (class_records.c). */
#include "resample/classes.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "resample/budget.h"
#include "io/pass.h"

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
    const int8_t *group_of;   /* [NCLASSES] */
    int nfiles, nparts;       /* parts: the groups, then the kept classes */
    uint64_t *lane;           /* [lanes][NCLASSES] */
    wpd_bounds *part;         /* [lanes][nfiles][nparts]: count and box */
} histogram;

/* The part (histogram.part) of a point of group index gi (group_of). */
static int part_of(int gi, int ngroups)
{
    return gi == WPD_GROUP_KEPT ? ngroups : gi;
}

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

static int count_lane(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    histogram *h = arg;
    uint64_t *count = h->lane + (size_t)pb->lane * NCLASSES;
    wpd_bounds *part = h->part + ((size_t)pb->lane * h->nfiles + pb->file) * h->nparts;
    const wpd_batch *b = pb->batch;
    for (size_t i = 0; i < b->n; i++) {
        long cls = class_checked(h->cloud, pb->file, h->field, b->records + i * b->record_size,
                                 err);
        if (cls < 0)
            return -1;
        count[cls]++;
        if (h->group_of[cls] != WPD_GROUP_DROPPED)
            wpd_bounds_add(&part[part_of(h->group_of[cls], h->nparts - 1)], b->xyz + 3 * i, 1);
    }
    return 0;
}

/* Sums the lanes' parts into the first lane's. */
static void sum_parts(histogram *h, int lanes)
{
    size_t per_lane = (size_t)h->nfiles * h->nparts;
    for (int l = 1; l < lanes; l++)
        for (size_t k = 0; k < per_lane; k++)
            wpd_bounds_union(&h->part[k], &h->part[l * per_lane + k]);
}

/* Finite points per class over the whole cloud into count[NCLASSES], and
 * into *parts ([nfiles][ngroups + 1], malloc'd) the count and box of each
 * group's and of the kept classes' points per file. */
static int class_histogram(wpd_cloud *cloud, const wpd_class_options *o,
                           const wpd_resample_options *opt, const int8_t *group_of,
                           int ngroups, uint64_t *count, wpd_bounds **parts, wpd_error *err)
{
    int nfiles = wpd_cloud_nfiles(cloud), nparts = ngroups + 1;
    size_t per_lane = (size_t)nfiles * nparts;
    int threads = pass_lanes(opt, wpd_pass_lane_bytes(cloud) + NCLASSES * sizeof(uint64_t) +
                                      per_lane * sizeof(wpd_bounds));
    histogram h = {cloud, &o->field, group_of, nfiles, nparts,
                   calloc((size_t)threads * NCLASSES, sizeof(uint64_t)),
                   malloc((size_t)threads * per_lane * sizeof(wpd_bounds))};
    *parts = h.part;
    if (!h.lane || !h.part) {
        free(h.lane);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the class histogram");
    }
    for (size_t k = 0; k < (size_t)threads * per_lane; k++)
        wpd_bounds_reset(&h.part[k]);
    wpd_pass pass = {.cloud = cloud, .threads = threads, .lane = count_lane, .arg = &h,
                     .progress = opt->progress};
    wpd_progress_phase(opt->progress, "classes", wpd_cloud_count(cloud), "points");
    int rc = wpd_cloud_rewind(cloud, err) || wpd_pass_run(&pass, err) ? -1 : 0;
    wpd_progress_end(opt->progress);
    for (int l = 0; l < threads; l++)
        for (size_t k = 0; k < NCLASSES; k++)
            count[k] += h.lane[(size_t)l * NCLASSES + k];
    sum_parts(&h, threads);
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

void wpd_class_groups_of(const wpd_class_options *o, int8_t *group_of)
{
    for (long c = 0; c < NCLASSES; c++) {
        wpd_class_role role = wpd_class_role_of(o, c);
        group_of[c] = role == WPD_CLASS_DROP   ? WPD_GROUP_DROPPED
                      : role == WPD_CLASS_KEEP ? WPD_GROUP_KEPT
                                               : 0;
        for (int i = 0; role == WPD_CLASS_COUNT && i < o->ncounts; i++)
            if (o->counts[i].cls == c)
                group_of[c] = (int8_t)(1 + i);
    }
}

static void add_times(wpd_resample_timings *sum, const wpd_resample_timings *t)
{
    sum->bounds += t->bounds, sum->scan += t->scan, sum->plan += t->plan;
    sum->tile += t->tile, sum->poisson += t->poisson, sum->exact += t->exact;
    sum->smooth += t->smooth, sum->merge += t->merge, sum->total += t->total;
}

/* Runs the driver for group g over the cloud filtered to it, in what the
 * budget leaves beside the runs already held (the samples of groups
 * resampled in memory; a tiled group's are in files). */
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

/* ------------------------------------------------------- the output's facts */

/* The lines of the report: every class present in the input (their
 * output counts come from the records pass). */
static int class_lines(const wpd_class_options *o, const uint64_t *in, wpd_class_result *out,
                       wpd_error *err)
{
    int n = 0;
    for (long c = 0; c < NCLASSES; c++)
        n += in[c] > 0;
    out->lines = calloc((size_t)(n ? n : 1), sizeof *out->lines);
    if (!out->lines)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (long c = 0; c < NCLASSES; c++)
        if (in[c])
            out->lines[out->nlines++] = (wpd_class_line){c, wpd_class_role_of(o, c), in[c], 0};
    return 0;
}

/* Output points and their box per file: the kept classes' and the whole
 * groups' points as the histogram saw them (parts[nfiles][ngroups + 1]),
 * the resampled groups' samples as their runs counted them. Also the
 * points not dropped per file (the records pass's global indices). */
static int output_per_file(wpd_class_result *out, const wpd_bounds *parts, wpd_error *err)
{
    wpd_resample_result *m = &out->merged;
    size_t nf = (size_t)m->nfiles, alloc = nf ? nf : 1;
    m->file_count = calloc(alloc, sizeof *m->file_count);
    m->file_samples = calloc(alloc, sizeof *m->file_samples);
    m->file_bounds = malloc(alloc * sizeof *m->file_bounds);
    if (!m->file_count || !m->file_samples || !m->file_bounds)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (size_t f = 0; f < nf; f++) {
        const wpd_bounds *part = parts + f * (size_t)(out->ngroups + 1);
        wpd_bounds_reset(&m->file_bounds[f]);
        for (int i = 0; i <= out->ngroups; i++) {
            const wpd_class_group *g = i < out->ngroups ? &out->groups[i] : NULL;
            m->file_count[f] += part[i].count;
            if (!g || g->whole)
                wpd_bounds_union(&m->file_bounds[f], &part[i]);
            else if (g->run.file_samples)
                wpd_bounds_union(&m->file_bounds[f], &g->run.file_bounds[f]);
        }
        m->file_samples[f] = m->file_bounds[f].count;
        m->count += m->file_samples[f];
    }
    return 0;
}

/* The merged result's run facts: the first group run's (its tile boxes
 * move over), times and sharp samples summed. */
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
            m->labelled |= r->labelled;
            m->sharp_samples += r->sharp_samples;
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
    m->cover_hinted = first->cover_hinted;
    m->sharp_labelled = first->sharp_labelled;
    m->in_memory = first->in_memory, m->tiles = first->tiles, m->colours = first->colours;
    m->largest_tile = first->largest_tile, m->spill = first->spill;
    m->work_file_bytes = first->work_file_bytes;
    m->tile_box = first->tile_box; /* moved: the report lists the boxes */
    first->tile_box = NULL;
}

/* The output filter (the classes not dropped) for the records pass. */
static int output_filter(const wpd_class_options *o, wpd_class_result *out, wpd_error *err)
{
    uint8_t *accept = out->output_accept = malloc(NCLASSES);
    if (!accept)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    for (long c = 0; c < NCLASSES; c++)
        accept[c] = out->group_of[c] != WPD_GROUP_DROPPED;
    out->output_filter = (wpd_point_filter){o->field, accept};
    return 0;
}

/* The groups' runs, each in what the earlier ones leave of the budget. */
static int run_groups(wpd_cloud *cloud, const wpd_class_options *o,
                      const wpd_resample_options *opt, wpd_class_result *out, wpd_error *err)
{
    uint8_t *accept = malloc(NCLASSES);
    if (!accept)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    size_t held = 0;
    int rc = 0;
    for (int i = 0; rc == 0 && i < out->ngroups; i++) {
        wpd_class_group *g = &out->groups[i];
        if (g->whole || g->points == 0 || g->target == 0)
            continue;
        if ((rc = run_group(cloud, o, opt, held, g, accept, err)) == 0)
            held += wpd_runs_memory_bytes(g->run.samples);
    }
    free(accept);
    return rc;
}

int wpd_resample_by_class(wpd_cloud *cloud, const wpd_class_options *o,
                          const wpd_resample_options *opt, int quiet, wpd_class_result *out,
                          wpd_error *err)
{
    memset(out, 0, sizeof *out);
    uint64_t *count = calloc(NCLASSES, sizeof *count);
    wpd_bounds *parts = NULL;
    int rc = -1;
    double t = omp_get_wtime();
    out->group_of = malloc(NCLASSES);
    if (!count || !out->group_of) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
        goto done;
    }
    wpd_class_groups_of(o, out->group_of);
    if (class_histogram(cloud, o, opt, out->group_of, 1 + o->ncounts, count, &parts, err) ||
        plan_groups(o, count, quiet, out, err))
        goto done;
    if (!quiet)
        notice_absent(o, count);
    out->histogram_seconds = omp_get_wtime() - t;
    out->merged.record_size = wpd_cloud_header(cloud, 0)->schema.record_size;
    out->merged.nfiles = wpd_cloud_nfiles(cloud);
    if (run_groups(cloud, o, opt, out, err) || output_per_file(out, parts, err) ||
        class_lines(o, count, out, err) || output_filter(o, out, err))
        goto done;
    merged_facts(out, count);
    rc = out->merged.count ? 0 : wpd_fail(err, WPD_E_INPUT, "%s: no point left to write "
                                          "(every class dropped or counted to 0)",
                                          wpd_cloud_header(cloud, 0)->path);
done:
    free(count);
    free(parts);
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
    free(r->group_of);
    memset(r, 0, sizeof *r);
}
