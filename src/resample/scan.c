#include "resample/scan.h"

#include "resample/budget.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "par/par.h"
#include "io/pass.h"
#include "method/ladder.h"

/* Both passes compute sums and sets, which do not depend on the order of
 * the points nor on which thread counts which: an unordered pass (pass.h)
 * in which each lane counts its batches into a counter of its own. */

/* What one lane has counted; combined at the end of the pass. */
typedef struct counter {
    wpd_bounds box;
    uint64_t *file_count;     /* [nfiles] */
    wpd_ladder ladder;        /* scan pass only */
    uint64_t *density;        /* scan pass only */
    uint8_t *paper;           /* scan pass only: bitmap of the paper's voxels, or NULL */
    int failed;               /* 1 out of memory */
} counter;

static void counters_free(counter *c, int threads)
{
    for (int t = 0; c && t < threads; t++) {
        free(c[t].file_count);
        wpd_ladder_free(&c[t].ladder);
        free(c[t].density);
        free(c[t].paper);
    }
    free(c);
}

/* Voxels of the paper's scale along axis a. */
static uint64_t paper_dim(const wpd_scan *s, int a)
{
    return (uint64_t)(s->extent[a] / s->paper_edge) + 1;
}

/* Voxels of the paper's scale in the box: 0 when more than the bitmap
 * holds (the estimate then interpolates the ladder's counts). */
static uint64_t paper_cells(const wpd_scan *s)
{
    if (!(s->paper_frac > 0)) /* not asked for */
        return 0;
    double cells = 1;
    for (int a = 0; a < 3; a++)
        cells *= (double)paper_dim(s, a);
    return cells <= WPD_SCAN_PAPER_CELLS ? (uint64_t)cells : 0;
}

static void paper_put(const wpd_scan *s, uint8_t *bits, const double p[3])
{
    uint64_t key = 0;
    double inv = 1.0 / s->paper_edge; /* as wpd_voxel_counts indexes voxels */
    for (int a = 2; a >= 0; a--) {
        uint64_t i = (uint64_t)(p[a] * inv), dim = paper_dim(s, a);
        key = key * dim + (i < dim ? i : dim - 1);
    }
    bits[key >> 3] |= (uint8_t)(1u << (key & 7));
}

/* Counters for the bounds pass (scan == NULL) or the scan pass. */
static counter *counters_new(wpd_cloud *cloud, const wpd_scan *scan, size_t voxel_cap,
                             int threads, size_t cells)
{
    counter *c = calloc((size_t)threads, sizeof *c);
    int ok = c != NULL;
    for (int t = 0; ok && t < threads; t++) {
        wpd_bounds_reset(&c[t].box);
        ok = (c[t].file_count = calloc((size_t)wpd_cloud_nfiles(cloud), sizeof(uint64_t))) != NULL;
        if (ok && scan)
            ok = wpd_ladder_init(&c[t].ladder, scan->extent, scan->count, voxel_cap,
                                 scan->wanted_voxels) == 0 &&
                 (c[t].density = calloc(cells, sizeof *c[t].density)) &&
                 (!paper_cells(scan) || (c[t].paper = calloc(paper_cells(scan) / 8 + 1, 1)));
    }
    if (!ok) {
        counters_free(c, threads);
        return NULL;
    }
    return c;
}

static void count_batch(const wpd_scan *s, counter *c, const wpd_batch *b)
{
    for (size_t i = 0; i < b->n && !c->failed; i++) {
        double p[3];
        /* Clamped into the box: a header box that turns out to be off
         * leaves points outside it (that pass is then done again). */
        for (int a = 0; a < 3; a++) {
            double v = b->xyz[3 * i + a] - s->origin[a];
            p[a] = v < 0 ? 0 : v > s->extent[a] ? s->extent[a] : v;
        }
        c->density[wpd_scan_cell_of(s, p)]++;
        if (c->paper)
            paper_put(s, c->paper, p);
        c->failed = wpd_ladder_put(&c->ladder, p) != 0;
    }
}

typedef struct count_job {
    const wpd_scan *scan;     /* NULL: the bounds pass */
    counter *c;               /* [lanes] */
    uint64_t *unit_points;    /* [units] or NULL: finite points per unit (a unit is
                                 read by one lane: no two write one entry) */
} count_job;

static int count_lane(void *arg, wpd_pass_batch *pb, wpd_error *err)
{
    count_job *job = arg;
    /* A private copy while counting: the counters of all lanes share cache
     * lines. */
    counter mine = job->c[pb->lane];
    wpd_bounds_add(&mine.box, pb->batch->xyz, pb->batch->n);
    mine.file_count[pb->file] += pb->batch->n;
    if (job->scan)
        count_batch(job->scan, &mine, pb->batch);
    job->c[pb->lane] = mine;
    if (job->unit_points && pb->unit != WPD_PASS_NO_UNIT)
        job->unit_points[pb->unit] += pb->batch->n;
    if (mine.failed)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
    return 0;
}

/* Streams the cloud once on `threads` lanes into the counters: bounds and
 * points per file, and with scan != NULL the voxels and the density.
 * Returns 0, or -1 with err set (read error, or memory for the ladder). */
static int count_cloud(wpd_cloud *cloud, const wpd_par *par, wpd_scan *scan,
                       counter *c, int threads, wpd_progress *pg, wpd_error *err)
{
    count_job job = {scan, c, scan ? scan->unit_points : NULL};
    int ranks = wpd_par_ranks(par);
    wpd_pass pass = {.cloud = cloud, .threads = threads, .lane = count_lane, .arg = &job,
                     .progress = pg, .share = ranks > 1 ? wpd_par_rank(par) : 0,
                     .shares = ranks > 1 ? ranks : 0, .dropped = scan ? &scan->dropped : NULL};
    return wpd_pass_run(&pass, err);
}

/* With several ranks (par/par.h), each has counted its share of the units
 * (sums and sets, like the lanes; an input that cannot seek is read whole
 * by every rank, which counts its share of the batches): the box and points per file summed over
 * the ranks into box and file_count. Every rank calls it, whether its own
 * count failed (rc -1, err set) or not: it agrees first. Returns 0 or -1. */
static int sum_box_over_ranks(const wpd_par *par, int rc, wpd_bounds *box,
                              uint64_t *file_count, int nfiles, wpd_error *err)
{
    if (wpd_par_ranks(par) < 2)
        return rc;
    if (rc == 0)
        wpd_error_clear(err);
    if (wpd_par_agree(par, err) || wpd_par_min_f64(par, box->min, 3, err) ||
        wpd_par_max_f64(par, box->max, 3, err) || wpd_par_sum_u64(par, &box->count, 1, err))
        return -1;
    return wpd_par_sum_u64(par, file_count, (size_t)nfiles, err);
}

/* The ranks' densities, paper voxels and ladders into c (this rank's lanes
 * already combined into it): every rank gets the counts of all. */
static int combine_ranks(const wpd_par *par, const wpd_scan *s, counter *c, size_t cells,
                         wpd_error *err)
{
    if (wpd_par_ranks(par) < 2)
        return 0;
    uint8_t *mine = NULL, *all = NULL;
    size_t n = 0, ranks = (size_t)wpd_par_ranks(par);
    size_t *off = calloc(ranks, sizeof *off), *len = calloc(ranks, sizeof *len);
    int rc = -1;
    if (!off || !len || wpd_ladder_pack(&c->ladder, &mine, &n)) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
        mine = NULL;
    }
    if (wpd_par_agree(par, err) || wpd_par_sum_u64(par, c->density, cells, err) ||
        (c->paper && wpd_par_or_u8(par, c->paper, paper_cells(s) / 8 + 1, err)) ||
        wpd_par_gather_all(par, mine, n, &all, off, len, err))
        goto done;
    /* In rank order: the same ladder on every rank (and the one a single
     * process counts, wpd_ladder_merge). */
    for (size_t k = 0; k < ranks; k++)
        if (k != (size_t)wpd_par_rank(par) &&
            wpd_ladder_merge_packed(&c->ladder, all + off[k], len[k])) {
            wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
            goto done;
        }
    rc = 0;
done:
    free(mine);
    free(all);
    free(off);
    free(len);
    return rc;
}

/* The actual box and points per file of what the counters saw. */
static void sum_counters(const counter *c, int threads, int nfiles, wpd_bounds *box,
                         uint64_t *file_count)
{
    wpd_bounds_reset(box);
    memset(file_count, 0, (size_t)nfiles * sizeof *file_count);
    for (int t = 0; t < threads; t++) {
        for (int a = 0; a < 3 && c[t].box.count; a++) {
            box->min[a] = fmin(box->min[a], c[t].box.min[a]);
            box->max[a] = fmax(box->max[a], c[t].box.max[a]);
        }
        box->count += c[t].box.count;
        for (int f = 0; f < nfiles; f++)
            file_count[f] += c[t].file_count[f];
    }
}

/* Pass 1 when the headers declare no usable box: the actual one. */
static int bounds_pass(wpd_cloud *cloud, const wpd_par *par, wpd_scan *s, int threads,
                       size_t room, wpd_progress *pg, wpd_bounds *box, wpd_error *err)
{
    threads = wpd_threads_within(threads, room, wpd_pass_lane_bytes(cloud));
    counter *c = counters_new(cloud, NULL, 0, threads, 0);
    if (!c)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    int rc = count_cloud(cloud, par, NULL, c, threads, pg, err);
    if (rc == 0)
        sum_counters(c, threads, s->nfiles, box, s->file_count);
    counters_free(c, threads);
    return sum_box_over_ranks(par, rc, box, s->file_count, s->nfiles, err);
}

/* The frame: origin at the box's minimum corner. */
static void set_frame(wpd_scan *s, const wpd_bounds *box)
{
    s->count = box->count;
    for (int a = 0; a < 3; a++) {
        s->origin[a] = box->min[a];
        s->extent[a] = box->max[a] - box->min[a];
    }
}

static void init_grid(wpd_scan *s)
{
    double longest = fmax(s->extent[0], fmax(s->extent[1], s->extent[2]));
    s->paper_edge = longest > 0 && s->paper_frac > 0 ? s->paper_frac * longest : 1;
    s->cell = longest > 0 ? longest / WPD_SCAN_GRID * (1 + 1e-9) : 1.0;
    s->inv_cell = 1.0 / s->cell;
    for (int a = 0; a < 3; a++) {
        s->dim[a] = (int)floor(s->extent[a] / s->cell) + 1;
        if (s->dim[a] > WPD_SCAN_GRID)
            s->dim[a] = WPD_SCAN_GRID;
    }
}

/* Sums the threads' densities and paper voxels into c[0] and merges their
 * ladders into its ladder: the same as one thread counting everything. */
static int combine_lanes(const wpd_scan *s, counter *c, int threads, size_t cells)
{
    uint64_t bytes = paper_cells(s) ? paper_cells(s) / 8 + 1 : 0;
    for (int t = 1; t < threads; t++) {
        for (size_t i = 0; i < cells; i++)
            c[0].density[i] += c[t].density[i];
        for (uint64_t i = 0; i < bytes; i++)
            c[0].paper[i] |= c[t].paper[i];
        if (wpd_ladder_merge(&c[0].ladder, &c[t].ladder))
            return -1;
    }
    return 0;
}

/* The combined counts of c (all lanes, all ranks) into s: density, paper
 * voxels and the counts per scale. */
static int finish_counts(wpd_scan *s, counter *c, size_t cells)
{
    memcpy(s->density, c->density, cells * sizeof *s->density);
    uint64_t bytes = paper_cells(s) ? paper_cells(s) / 8 + 1 : 0;
    s->paper_voxels = 0;
    for (uint64_t i = 0; i < bytes; i++)
        s->paper_voxels += (uint64_t)__builtin_popcount(c->paper[i]);
    return wpd_ladder_finish(&c->ladder, s->edge, s->voxels, &s->nscales, &s->nestimated);
}

/* Pass 2 in the frame of s; also the actual box and points per file. */
static int scan_pass(wpd_cloud *cloud, const wpd_par *par, wpd_scan *s, size_t voxel_cap,
                     int threads, size_t room, wpd_progress *pg, wpd_bounds *actual,
                     wpd_error *err)
{
    init_grid(s);
    size_t cells = (size_t)s->dim[0] * s->dim[1] * s->dim[2];
    /* A lane's own: its ladder (the exact set and the samples' sets, each
     * up to 32 bytes a key while coarsening), density grid, batch and
     * cloud. */
    size_t sets = 1 + (size_t)wpd_ladder_samples(voxel_cap, s->wanted_voxels);
    size_t per_thread =
        sets * 32 * voxel_cap + cells * sizeof *s->density + wpd_pass_lane_bytes(cloud);
    /* The budget's fixed share holds the first lane's exact set; its
     * sampled sets come out of the room of the others. */
    size_t first_extra = (sets - 1) * 32 * voxel_cap;
    room = room > first_extra ? room - first_extra : 0;
    threads = wpd_threads_within(threads, room, per_thread);
    free(s->density);
    s->density = calloc(cells, sizeof *s->density);
    counter *c = s->density ? counters_new(cloud, s, voxel_cap, threads, cells) : NULL;
    if (!c)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
    if (s->unit_points)
        memset(s->unit_points, 0, s->nunits * sizeof *s->unit_points);
    int rc = count_cloud(cloud, par, s, c, threads, pg, err);
    if (rc == 0 && combine_lanes(s, c, threads, cells))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
    if (rc == 0)
        sum_counters(c, threads, s->nfiles, actual, s->file_count);
    rc = sum_box_over_ranks(par, rc, actual, s->file_count, s->nfiles, err);
    if (rc == 0)
        rc = combine_ranks(par, s, c, cells, err);
    if (rc == 0 && s->unit_points) /* each unit was counted by one rank */
        rc = wpd_par_sum_u64(par, s->unit_points, s->nunits, err);
    if (rc == 0 && wpd_par_ranks(par) > 1)
        rc = wpd_par_sum_u64(par, &s->dropped, 1, err);
    if (rc == 0 && finish_counts(s, c, cells))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
    counters_free(c, threads);
    return rc;
}

int wpd_scan_run(wpd_cloud *cloud, const wpd_par *par, size_t voxel_cap, double wanted_voxels,
                 double paper_frac, int threads, size_t room, wpd_progress *progress,
                 wpd_scan *out, wpd_error *err)
{
    memset(out, 0, sizeof *out);
    out->wanted_voxels = wanted_voxels;
    out->paper_frac = paper_frac;
    threads = threads < 1 ? 1 : threads;
    out->nfiles = wpd_cloud_nfiles(cloud);
    out->file_count = calloc((size_t)out->nfiles, sizeof *out->file_count);
    if (!out->file_count)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    /* With several ranks, the points of each unit: where each rank's share
     * of the records pass starts reading (docs/scale-out.md). */
    if (wpd_par_ranks(par) > 1 && wpd_pass_units(cloud, &out->nunits, err))
        goto fail;
    if (out->nunits && !(out->unit_points = calloc(out->nunits, sizeof *out->unit_points))) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory");
        goto fail;
    }
    /* LAS headers declare the box: the scan starts in its frame and checks
     * it (wpd_bounds_tight), saving a pass over the inputs; only when the
     * headers are off does a second scan in the actual frame follow. */
    wpd_bounds declared, actual;
    int have_declared = wpd_cloud_declared_bounds(cloud, &declared);
    double t = omp_get_wtime();
    if (have_declared) {
        set_frame(out, &declared);
    } else {
        wpd_progress_phase(progress, "bounds", wpd_cloud_count(cloud), "points");
        if (bounds_pass(cloud, par, out, threads, room, progress, &actual, err))
            goto fail;
        wpd_progress_end(progress);
        set_frame(out, &actual);
    }
    out->bounds_seconds = omp_get_wtime() - t;
    t = omp_get_wtime();
    for (int pass = 0;; pass++) {
        if (out->count == 0) {
            wpd_fail(err, WPD_E_INPUT, "%s: no point with finite coordinates",
                     wpd_cloud_header(cloud, 0)->path);
            goto fail;
        }
        wpd_progress_phase(progress, "scan", out->count, "points");
        if (scan_pass(cloud, par, out, voxel_cap, threads, room, progress, &actual, err))
            goto fail;
        wpd_progress_end(progress);
        if (!have_declared || pass > 0 || wpd_bounds_tight(&declared, &actual))
            break;
        set_frame(out, &actual); /* the headers are off: count again */
    }
    if (wpd_cloud_rewind(cloud, err))
        goto fail;
    out->scan_seconds = omp_get_wtime() - t;
    return 0;
fail:
    wpd_scan_free(out);
    return -1;
}

void wpd_scan_free(wpd_scan *s)
{
    free(s->file_count);
    free(s->density);
    free(s->unit_points);
    memset(s, 0, sizeof *s);
}
