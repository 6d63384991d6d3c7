/* driver.c - wpd_resample_run: the phases of resample.h, once, over a
 * tile store that is either the spill or one tile in memory. */
#include "resample/resample.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "common/heap.h"
#include "common/testhook.h"
#include "resample/budget.h"
#include "resample/run.h"
#include "core/knn.h"
#include "method/ladder.h"
#include "method/radius.h"
#include "resample/sample_store.h"
#include "resample/ranks.h"
#include "resample/tile.h"
#include "resample/poisson.h"
#include "resample/exact.h"
#include "resample/smooth.h"
#include "resample/merge.h"
#include "resample/fixed.h"
#include "resample/hints.h"

static uint32_t record_size_of(const wpd_cloud *cloud)
{
    return wpd_cloud_header(cloud, 0)->schema.record_size;
}

int wpd_resample_in_memory(const wpd_cloud *cloud, const wpd_resample_options *opt)
{
    const wpd_params *p = &opt->params;
    return opt->min_tiles <= 1 &&
           wpd_budget_in_memory_bytes(wpd_cloud_count(cloud), record_size_of(cloud),
                                      opt->target, p->sharp, wpd_params_smooths(p)) <=
               opt->mem_bytes;
}

/* Occupied voxels at edge l, interpolated log-log between the two counted
 * scales around it (the ladder counts powers of two): for a paper scale
 * too fine to count exactly. */
static double voxels_at(const wpd_scan *s, double l)
{
    int lo = -1, hi = -1;
    for (int i = 0; i < s->nscales; i++) {
        if (s->voxels[i] == 0)
            continue;
        if (s->edge[i] <= l && (lo < 0 || s->edge[i] > s->edge[lo]))
            lo = i;
        if (s->edge[i] >= l && (hi < 0 || s->edge[i] < s->edge[hi]))
            hi = i;
    }
    if (lo < 0 || hi < 0 || lo == hi)
        return (double)s->voxels[lo >= 0 ? lo : hi >= 0 ? hi : 0];
    double f = log(l / s->edge[lo]) / log(s->edge[hi] / s->edge[lo]);
    return exp(log((double)s->voxels[lo]) * (1 - f) + log((double)s->voxels[hi]) * f);
}

/* The radius estimate, from the scan's voxel counts: the multiscale one
 * (radius.h), or the paper's eq. 3-4 at voxel_frac x the longest side. */
static double estimate_radius(const wpd_run *run)
{
    const wpd_params *p = run->p;
    const wpd_scan *s = &run->scan;
    if (p->radius > 0)
        return p->radius;
    if (p->radius_method == WPD_RADIUS_PAPER) {
        double m = s->paper_voxels ? (double)s->paper_voxels : voxels_at(s, s->paper_edge);
        return wpd_radius_paper_formula(m, s->paper_edge, run->opt->target, p->lambda);
    }
    wpd_radius_info ri;
    wpd_radius_from_counts(s->edge, s->voxels, s->nscales, run->opt->target, p->density, &ri);
    return ri.radius;
}

/* The count the plan sizes tiles for and the surface grids their cells
 * by: the target, or with a fixed radius r the count the scan's voxels
 * predict at r (radius.h: density x m(r) = n), so that -n, only a figure
 * to compare with then, does not change the output. */
static double plan_target(const wpd_run *run)
{
    if (!(run->opt->fixed_radius > 0))
        return (double)run->opt->target;
    double n = run->p->density * voxels_at(&run->scan, run->radius);
    return fmin(fmax(n, 1), (double)run->scan.count);
}

size_t wpd_run_exact_target(const wpd_run *run)
{
    double f = run->opt->density_factor;
    if (!(f > 0))
        return run->opt->target;
    size_t count = run->res->poisson_count;
    double n = nearbyint(f * (double)count);
    return n >= (double)count ? count : n < 1 ? 1 : (size_t)n;
}

static int copy_tile_boxes(wpd_run *run)
{
    const wpd_scan *s = &run->scan;
    double *box = malloc((size_t)run->plan.ntiles * 6 * sizeof *box);
    if (!box)
        return -1;
    for (int t = 0; t < run->plan.ntiles; t++)
        for (int a = 0; a < 3; a++) {
            const wpd_tile *tile = &run->plan.tiles[t];
            double lo = fmax(tile->box_lo[a], 0), hi = fmin(tile->box_hi[a], s->extent[a]);
            box[6 * t + a] = lo + s->origin[a];
            box[6 * t + 3 + a] = hi + s->origin[a];
        }
    run->res->tile_box = box;
    return 0;
}

static int check_budget(const wpd_run *run, wpd_error *err)
{
    size_t need = wpd_budget_min(run->opt->target, wpd_cloud_count(run->cloud), run->p->sharp);
    if (run->res->in_memory || run->opt->mem_bytes >= need)
        return 0;
    return wpd_fail(err, WPD_E_MEMORY,
                    "memory budget too small: %zu MiB given, at least %zu MiB needed for %llu "
                    "output points from %llu input points (raise --mem or lower -n)",
                    run->opt->mem_bytes >> 20, (need >> 20) + 1,
                    (unsigned long long)run->opt->target,
                    (unsigned long long)wpd_cloud_count(run->cloud));
}

/* scan -> radius -> plan: the frame, the radius and the tiles. */
static int scan_and_plan(wpd_run *run, wpd_error *err)
{
    wpd_resample_result *res = run->res;
    size_t mem = run->opt->mem_bytes;
    size_t room = mem > WPD_BUDGET_FIXED_BYTES ? mem - WPD_BUDGET_FIXED_BYTES : 0;
    double paper_frac = run->p->radius_method == WPD_RADIUS_PAPER ? run->p->voxel_frac : 0;
    double wanted = (double)run->opt->target / run->p->density;
    if (wpd_scan_run(run->cloud, run->opt->par, WPD_LADDER_KEYS, wanted, paper_frac,
                     run->threads, room, run->opt->progress, &run->scan, err))
        return -1;
    res->time.bounds = run->scan.bounds_seconds;
    res->time.scan = run->scan.scan_seconds;
    res->input_points = run->scan.count;
    res->dropped = run->scan.dropped;
    res->nfiles = run->scan.nfiles;
    res->file_count = malloc((size_t)res->nfiles * sizeof *res->file_count);
    if (!res->file_count)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    memcpy(res->file_count, run->scan.file_count, (size_t)res->nfiles * sizeof *res->file_count);
    res->nunits = run->scan.nunits;
    res->unit_points = run->scan.unit_points;
    run->scan.unit_points = NULL;
    double t = omp_get_wtime();
    res->radius_estimate = run->radius = estimate_radius(run);
    /* The halo carries the input surface across borders for smoothing:
     * samples move less than r, and the refinement changes r by little. */
    run->halo = 2.5 * run->radius;
    run->plan_target = plan_target(run);
    /* The input spacing is about 1.5 r sqrt(n / N); k = 13 neighbours lie
     * within ~1.7 spacings. */
    run->surface_dk = 2.5 * res->radius_estimate *
                      sqrt(run->plan_target / (double)run->scan.count);
    uint64_t max_points = res->in_memory ? run->scan.count
                                         : wpd_budget_max_tile_points(mem, (size_t)run->plan_target,
                                                                    run->scan.count, run->p->sharp);
    if (wpd_plan_tiles(&run->scan, max_points, res->in_memory ? 1 : run->opt->min_tiles,
                       run->halo, &run->plan, err))
        return -1;
    res->tiles = run->plan.ntiles;
    res->colours = run->plan.ncolours;
    res->largest_tile = run->plan.largest;
    if (copy_tile_boxes(run))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    if (wpd_store_open(run, err) || wpd_fixed_open(run, err) ||
        (wpd_par_ranks(run->opt->par) > 1 && wpd_run_assign_owners(run, err)))
        return -1;
    res->time.plan = omp_get_wtime() - t;
    return 0;
}

/* Where the ranks share the tiles, each spilled its own: the run's spill
 * is their sum. */
static int sum_spill_stats(wpd_run *run, wpd_error *err)
{
    wpd_spill_stats *st = &run->res->spill;
    uint64_t sum[3] = {st->points, st->raw_bytes, st->disk_bytes};
    wpd_error_clear(err);
    if (wpd_par_agree(run->opt->par, err) || wpd_par_sum_u64(run->opt->par, sum, 3, err))
        return -1;
    st->points = sum[0], st->raw_bytes = sum[1], st->disk_bytes = sum[2];
    return 0;
}

static int tile_phase(wpd_run *run, wpd_error *err)
{
    double t = omp_get_wtime();
    int rc = run->res->in_memory ? wpd_tiles_open_memory(&run->tiles, run->scan.count, err)
                                 : wpd_run_open_spill(run, &run->tiles, err);
    if (rc)
        return -1;
    wpd_progress_phase(run->opt->progress, run->res->in_memory ? "load" : "tile",
                       run->scan.count, "points");
    if (wpd_tile_pass(run, err))
        return -1;
    wpd_progress_end(run->opt->progress);
    wpd_tiles_stats(&run->tiles, &run->res->spill);
    run->res->time.tile = omp_get_wtime() - t;
    return wpd_run_spills_own_tiles(run) ? sum_spill_stats(run, err) : 0;
}

static int finish(wpd_run *run, wpd_error *err)
{
    double t = omp_get_wtime();
    wpd_test_stall("merge");
    if (wpd_merge_phase(run, err))
        return -1;
    run->res->time.merge = omp_get_wtime() - t;
    return 0;
}

/* The Poisson passes. With one tile in memory and smoothing to come, the
 * tile's surface grid is built first, with every thread, and the Poisson
 * pass runs on it (resample/poisson.c) instead of on a second grid over the
 * whole cloud. With --sharp the labelling builds it (resample/poisson.c). */
static int poisson_phase(wpd_run *run, wpd_error *err)
{
    const wpd_params *p = run->p;
    int surface = run->res->in_memory && wpd_params_smooths(p);
    if (surface && !p->sharp) {
        const wpd_tile_data *d = &run->tiles.mem;
        if (wpd_grid_build_knn(&run->surface, d->xyz, NULL, d->n, p->k, run->surface_dk,
                               run->threads, err))
            return -1;
    }
    return wpd_poisson_phase(run, err);
}

static int run_phases(wpd_run *run, wpd_error *err)
{
    wpd_resample_timings *tm = &run->res->time;
    wpd_test_stall("scan");
    if (scan_and_plan(run, err) || tile_phase(run, err))
        return -1;
    /* A fixed radius (a collection's later night) samples at it whatever
     * the count. */
    if (run->opt->target >= run->scan.count && !(run->opt->fixed_radius > 0))
        return wpd_take_all_phase(run, err) || finish(run, err) ? -1 : 0;
    /* The phase over all samples (the exact count) and the smoothing
     * start with the previous phase's free pages handed back (heap.h): the
     * peak is then the largest phase's, not their sum of holes. The tiles'
     * Poisson pass and the records pass reuse what the phase before left.
     * Measured on 100 M -> 1 M, --mem 512M: 205 -> 178 MB, 50 K more page
     * faults (about 0.3 s of system time). */
    double t = omp_get_wtime();
    wpd_test_stall("poisson");
    if (poisson_phase(run, err))
        return -1;
    tm->poisson = omp_get_wtime() - t;
    wpd_heap_release();
    t = omp_get_wtime();
    wpd_test_stall("exact");
    if (wpd_exact_phase(run, err))
        return -1;
    tm->exact = omp_get_wtime() - t;
    wpd_heap_release();
    t = omp_get_wtime();
    wpd_test_stall("smooth");
    if (wpd_smooth_phase(run, err))
        return -1;
    tm->smooth = omp_get_wtime() - t;
    return finish(run, err);
}

static int check_options(const wpd_resample_options *opt, wpd_error *err)
{
    const wpd_params *p = &opt->params;
    if (opt->target < 1)
        return wpd_fail(err, WPD_E_USAGE, "the target count must be at least 1");
    if (!(p->lambda > 0) || !(p->voxel_frac > 0) || !(p->density > 0))
        return wpd_fail(err, WPD_E_USAGE, "lambda %g, voxel_frac %g and density %g must be "
                        "positive", p->lambda, p->voxel_frac, p->density);
    if (p->k < 3 || p->k > 64)
        return wpd_fail(err, WPD_E_USAGE, "k = %d neighbours, expected 3..64", p->k);
    if (p->iterations < 0 || p->even_iterations < 0)
        return wpd_fail(err, WPD_E_USAGE, "%d smoothing iterations, %d even steps", p->iterations,
                        p->even_iterations);
    if (opt->fixed_radius < 0 || !isfinite(opt->fixed_radius) || opt->density_factor < 0 ||
        !isfinite(opt->density_factor) || (opt->nfixed && !opt->fixed_xyz))
        return wpd_fail(err, WPD_E_USAGE, "fixed radius %g, density factor %g: expected "
                        "finite values >= 0", opt->fixed_radius, opt->density_factor);
    return 0;
}

int wpd_resample_run(wpd_cloud *cloud, const wpd_resample_options *opt,
                     wpd_resample_result *res, wpd_error *err)
{
    memset(res, 0, sizeof *res);
    double t0 = omp_get_wtime();
    if (check_options(opt, err))
        return -1;
    wpd_run run = {.opt = opt, .p = &opt->params, .cloud = cloud, .res = res};
    if (opt->fixed_radius > 0) { /* one pass at it: no estimate, no refinement */
        run.fixed_params = opt->params;
        run.fixed_params.radius = opt->fixed_radius;
        run.fixed_params.max_passes = 1;
        run.p = &run.fixed_params;
    }
    run.record_size = res->record_size = record_size_of(cloud);
    run.threads = opt->params.threads > 0 ? opt->params.threads : omp_get_max_threads();
    res->in_memory = wpd_resample_in_memory(cloud, opt);
    if (check_budget(&run, err))
        return -1;
    int rc = run_phases(&run, err);
    wpd_store_close(&run);
    wpd_fixed_close(&run);
    wpd_grid_free(&run.surface);
    free(run.nearest);
    wpd_hints_close(&run);
    res->work_file_bytes = run.work_files.peak;
    wpd_tiles_close(&run.tiles);
    wpd_plan_free(&run.plan);
    wpd_scan_free(&run.scan);
    free(run.owner);
    if (rc) {
        wpd_resample_result_free(res);
    } else {
        res->radius = run.radius;
        res->time.total = omp_get_wtime() - t0;
    }
    return rc;
}

void wpd_resample_result_free(wpd_resample_result *res)
{
    wpd_runs_close(res->samples);
    free(res->file_samples);
    free(res->file_bounds);
    free(res->file_count);
    free(res->unit_points);
    free(res->tile_box);
    memset(res, 0, sizeof *res);
}
