#include "ooc/scan.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "wpd/ladder.h"

size_t wpd_scan_cell_of(const wpd_scan *s, const double p[3])
{
    size_t c[3];
    for (int a = 0; a < 3; a++) {
        double f = p[a] * s->inv_cell;
        long i = f < 0 ? 0 : (long)f;
        c[a] = (size_t)(i >= s->dim[a] ? s->dim[a] - 1 : i);
    }
    return c[0] + (size_t)s->dim[0] * (c[1] + (size_t)s->dim[1] * c[2]);
}

static int bounds_pass(wpd_cloud *cloud, wpd_scan *s, wpd_progress *pg, wpd_error *err)
{
    wpd_batch b;
    if (wpd_batch_init(&b, 65536, wpd_cloud_header(cloud, 0)->schema.record_size))
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    wpd_bounds box;
    wpd_bounds_reset(&box);
    long got;
    int file;
    int rc = wpd_cloud_rewind(cloud, err);
    while (rc == 0 && (got = wpd_cloud_read(cloud, &b, &file, err)) > 0) {
        wpd_bounds_add(&box, b.xyz, b.n);
        s->file_count[file] += b.n;
        wpd_progress_add(pg, b.n);
    }
    wpd_batch_free(&b);
    if (rc || got < 0)
        return -1;
    if (box.count == 0)
        return wpd_fail(err, WPD_E_INPUT, "%s: no point with finite coordinates",
                        wpd_cloud_header(cloud, 0)->path);
    s->count = box.count;
    for (int a = 0; a < 3; a++) {
        s->origin[a] = box.min[a];
        s->extent[a] = box.max[a] - box.min[a];
    }
    return 0;
}

static void init_grid(wpd_scan *s)
{
    double longest = fmax(s->extent[0], fmax(s->extent[1], s->extent[2]));
    s->cell = longest > 0 ? longest / WPD_SCAN_GRID * (1 + 1e-9) : 1.0;
    s->inv_cell = 1.0 / s->cell;
    for (int a = 0; a < 3; a++) {
        s->dim[a] = (int)floor(s->extent[a] / s->cell) + 1;
        if (s->dim[a] > WPD_SCAN_GRID)
            s->dim[a] = WPD_SCAN_GRID;
    }
}

static int scan_pass(wpd_cloud *cloud, wpd_scan *s, size_t voxel_cap, wpd_progress *pg,
                     wpd_error *err)
{
    wpd_ladder v;
    wpd_batch b;
    if (wpd_ladder_init(&v, s->extent, s->count, voxel_cap) ||
        wpd_batch_init(&b, 65536, wpd_cloud_header(cloud, 0)->schema.record_size)) {
        wpd_ladder_free(&v);
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
    }
    long got;
    int rc = wpd_cloud_rewind(cloud, err);
    while (rc == 0 && (got = wpd_cloud_read(cloud, &b, NULL, err)) > 0) {
        for (size_t i = 0; i < b.n && rc == 0; i++) {
            double p[3];
            for (int a = 0; a < 3; a++)
                p[a] = b.xyz[3 * i + a] - s->origin[a];
            s->density[wpd_scan_cell_of(s, p)]++;
            if (wpd_ladder_put(&v, p))
                rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
        }
        wpd_progress_add(pg, b.n);
    }
    if (rc == 0 && got < 0)
        rc = -1;
    if (rc == 0 && wpd_ladder_finish(&v, s->edge, s->voxels, &s->nscales))
        rc = wpd_fail(err, WPD_E_MEMORY, "out of memory for the voxel scan");
    wpd_batch_free(&b);
    wpd_ladder_free(&v);
    return rc;
}

int wpd_scan_run(wpd_cloud *cloud, size_t voxel_cap, wpd_progress *progress, wpd_scan *out,
                 wpd_error *err)
{
    memset(out, 0, sizeof *out);
    out->nfiles = wpd_cloud_nfiles(cloud);
    out->file_count = calloc((size_t)out->nfiles, sizeof *out->file_count);
    if (!out->file_count)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory");
    double t = omp_get_wtime();
    wpd_progress_phase(progress, "bounds", wpd_cloud_count(cloud), "points");
    if (bounds_pass(cloud, out, progress, err))
        goto fail;
    wpd_progress_end(progress);
    out->bounds_seconds = omp_get_wtime() - t;
    t = omp_get_wtime();
    init_grid(out);
    out->density = calloc((size_t)out->dim[0] * out->dim[1] * out->dim[2], sizeof *out->density);
    if (!out->density) {
        wpd_fail(err, WPD_E_MEMORY, "out of memory for the density grid");
        goto fail;
    }
    wpd_progress_phase(progress, "scan", out->count, "points");
    if (scan_pass(cloud, out, voxel_cap, progress, err) || wpd_cloud_rewind(cloud, err))
        goto fail;
    wpd_progress_end(progress);
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
    memset(s, 0, sizeof *s);
}
