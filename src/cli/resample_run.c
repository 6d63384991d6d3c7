/* resample_run.c - the in-memory and out-of-core runs of `wpd resample`. */
#include "cli/resample_run.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "wpd/ladder.h"

/* Memory the one-block path needs for n points of record_size bytes:
 * records and coordinates, the Poisson and surface grids (measured: 380 MB
 * peak for the 2.27 M-point NC Raleigh scan to 100 K, 38-byte records). */
size_t wpd_in_memory_bytes(uint64_t n, uint32_t record_size)
{
    return (size_t)n * (record_size + 140) + ((size_t)32 << 20);
}

/* The whole cloud in memory: records and coordinates relative to origin. */
typedef struct loaded_cloud {
    size_t n;
    uint32_t record_size;
    uint8_t *records;
    double *xyz;
    uint64_t *gid;
    double origin[3];         /* minimum corner of the frame box */
    double extent[3];         /* size of the frame box */
} loaded_cloud;

static void loaded_free(loaded_cloud *c)
{
    free(c->records);
    free(c->xyz);
    free(c->gid);
    memset(c, 0, sizeof *c);
}

static int load_cloud(wpd_cloud *cloud, loaded_cloud *out, wpd_progress *pg, wpd_error *err)
{
    memset(out, 0, sizeof *out);
    uint64_t cap = wpd_cloud_count(cloud);
    out->record_size = wpd_cloud_header(cloud, 0)->schema.record_size;
    out->records = malloc(cap ? cap * out->record_size : 1);
    out->xyz = malloc((cap ? cap : 1) * 3 * sizeof *out->xyz);
    out->gid = malloc((cap ? cap : 1) * sizeof *out->gid);
    wpd_batch b;
    if (!out->records || !out->xyz || !out->gid ||
        wpd_batch_init(&b, 65536, out->record_size)) {
        loaded_free(out);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory loading %llu points",
                        (unsigned long long)cap);
    }
    long got;
    while ((got = wpd_cloud_read(cloud, &b, NULL, err)) > 0) {
        memcpy(out->records + out->n * out->record_size, b.records, b.n * out->record_size);
        memcpy(out->xyz + 3 * out->n, b.xyz, b.n * 3 * sizeof *b.xyz);
        out->n += b.n;
        wpd_progress_add(pg, b.n);
    }
    wpd_batch_free(&b);
    if (got < 0) {
        loaded_free(out);
        return -1;
    }
    /* The frame the engine would use (wpd_bounds_tight): the declared box
     * when it fits the points, else theirs. */
    wpd_bounds bounds, declared;
    wpd_bounds_reset(&bounds);
    wpd_bounds_add(&bounds, out->xyz, out->n);
    if (wpd_cloud_declared_bounds(cloud, &declared) && wpd_bounds_tight(&declared, &bounds))
        bounds = declared;
    for (int k = 0; k < 3; k++) {
        out->origin[k] = out->n ? bounds.min[k] : 0.0;
        out->extent[k] = out->n ? bounds.max[k] - bounds.min[k] : 0.0;
    }
    for (size_t i = 0; i < out->n; i++) {
        out->gid[i] = i;
        for (int k = 0; k < 3; k++)
            out->xyz[3 * i + k] -= out->origin[k];
    }
    return 0;
}

int wpd_run_in_memory(wpd_cloud *cloud, uint64_t target, const wpd_params *params_in,
                      wpd_progress *pg, wpd_selection *sel, uint64_t **file_count,
                      wpd_run_info *info, wpd_error *err)
{
    loaded_cloud c;
    wpd_result res = {0};
    double t0 = omp_get_wtime();
    wpd_progress_phase(pg, "load", wpd_cloud_count(cloud), "points");
    if (load_cloud(cloud, &c, pg, err))
        return -1;
    wpd_progress_end(pg);
    info->t_load = omp_get_wtime() - t0;
    int rc = -1;
    wpd_params params = *params_in;
    /* The multiscale radius as the out-of-core scan computes it, so that a
     * cloud gives the same samples whether it fits --mem or is tiled. */
    if (params.radius_method == WPD_RADIUS_MULTISCALE && target < c.n) {
        double t = omp_get_wtime();
        params.radius =
            wpd_ladder_radius(c.xyz, c.n, c.extent, target, params.density, params.threads);
        if (params.radius < 0) {
            wpd_fail(err, WPD_E_MEMORY, "out of memory for the radius estimate");
            goto done;
        }
        info->t_radius = omp_get_wtime() - t;
    }
    wpd_block block = {.n = c.n, .xyz = c.xyz, .gid = c.gid};
    wpd_progress_phase(pg, "resample", 0, "points");
    if (wpd_run_block(&block, target, &params, &res, err))
        goto done;
    wpd_progress_add(pg, res.count);
    wpd_progress_end(pg);
    sel->n = res.count;
    sel->record_size = c.record_size;
    sel->moved = params.smooth && target < c.n;
    sel->precision = res.radius / 1000;
    sel->gid = malloc((res.count ? res.count : 1) * sizeof *sel->gid);
    sel->xyz = malloc((res.count ? res.count : 1) * 3 * sizeof *sel->xyz);
    sel->records = malloc((res.count ? res.count : 1) * c.record_size);
    *file_count = calloc((size_t)wpd_cloud_nfiles(cloud), sizeof **file_count);
    if (!sel->gid || !sel->xyz || !sel->records || !*file_count) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for %zu samples", res.count);
        goto done;
    }
    for (size_t i = 0; i < res.count; i++) {
        sel->gid[i] = res.gid[i];
        for (int k = 0; k < 3; k++)
            sel->xyz[3 * i + k] = res.xyz[3 * i + k] + c.origin[k];
        memcpy(sel->records + i * c.record_size, c.records + (size_t)res.index[i] * c.record_size,
               c.record_size);
    }
    /* Finite points per file, for --per-input: the cloud counted them. */
    for (int f = 0; f < wpd_cloud_nfiles(cloud); f++)
        (*file_count)[f] = wpd_cloud_delivered(cloud, f);
    info->input_points = c.n;
    info->count = res.count;
    info->radius = res.radius;
    info->radius_estimate = res.radius_estimate;
    info->first_pass_count = res.first_pass_count;
    info->poisson_count = res.poisson_count;
    info->passes = res.passes;
    info->prune_passes = res.prune_passes;
    info->open_cells = res.open_cells;
    info->pulled = res.pulled_to_surface;
    info->t_radius += res.time.radius;
    info->t_poisson = res.time.poisson;
    info->t_exact = res.time.exact;
    info->t_smooth = res.time.normals + res.time.smooth;
    rc = 0;
done:
    wpd_result_free(&res);
    loaded_free(&c);
    return rc;
}

int wpd_run_out_of_core(wpd_cloud *cloud, const wpd_engine_options *eo, wpd_selection *sel,
                        uint64_t **file_count, double **tile_box, wpd_run_info *info,
                        wpd_error *err)
{
    if (eo->params.sharp)
        return wpd_fail(err, WPD_E_USAGE, "--sharp needs the cloud in memory (it is not "
                        "implemented out of core yet): raise --mem above %zu MiB",
                        wpd_in_memory_bytes(wpd_cloud_count(cloud),
                                            wpd_cloud_header(cloud, 0)->schema.record_size) >> 20);
    wpd_engine_result r;
    if (wpd_engine_run(cloud, eo, &r, err))
        return -1;
    sel->n = r.count;
    sel->gid = r.gid;
    sel->xyz = r.xyz;
    sel->records = r.records;
    sel->record_size = r.record_size;
    sel->moved = eo->params.smooth && eo->target < r.input_points;
    sel->precision = r.radius / 1000;
    *file_count = r.file_count;
    r.gid = NULL, r.xyz = NULL, r.records = NULL, r.file_count = NULL;
    info->input_points = r.input_points;
    info->count = r.count;
    info->radius = r.radius;
    info->radius_estimate = r.radius_estimate;
    info->first_pass_count = r.first_pass_count;
    info->poisson_count = r.poisson_count;
    info->passes = r.full_passes;
    info->prune_passes = r.prune_passes;
    info->open_cells = r.open_cells;
    info->pulled = r.pulled_to_surface;
    info->tiles = r.tiles;
    info->colours = r.colours;
    info->largest_tile = r.largest_tile;
    info->tile_box = *tile_box = r.tile_box;
    r.tile_box = NULL;
    info->spill = r.spill;
    info->t_load = r.time.bounds;
    info->t_scan = r.time.scan;
    info->t_tile = r.time.tile;
    info->t_poisson = r.time.poisson;
    info->t_exact = r.time.exact;
    info->t_smooth = r.time.smooth + r.time.merge;
    wpd_engine_result_free(&r);
    return 0;
}

