#include "cli/selection.h"

#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/testhook.h"
#include "io/layout.h"

/* 1 when a PLY output's x, y or z is float32 and float32 spacing at the
 * output's magnitude is coarser than precision: moved positions would be
 * rounded away (float32 UTM northings are spaced half a metre apart). */
static int needs_wider_coordinates(const wpd_header *out, const wpd_bounds *b, double precision)
{
    if (out->format != WPD_FMT_PLY)
        return 0;
    const wpd_schema *s = &out->schema;
    int axes[3] = {s->dim_x, s->dim_y, s->dim_z};
    for (int k = 0; k < 3; k++) {
        if (axes[k] < 0 || s->dims[axes[k]].type != WPD_F32)
            continue;
        double mag = fmax(fabs(b->min[k]), fabs(b->max[k]));
        if (mag > 0 && ldexp(1.0, ilogb(mag) - 23) > precision)
            return 1;
    }
    return 0;
}

/* The output's layout: the input's in the output format, coordinates
 * widened where smoothing needs it, the label field last; *label gets its
 * index (-1 without labels). */
static int plan_output(const wpd_selection *sel, size_t first, size_t count,
                       const wpd_header *in, const char *path, wpd_header *out,
                       wpd_layout_map *map, int *label, wpd_error *err)
{
    wpd_bounds bounds;
    wpd_bounds_reset(&bounds);
    wpd_bounds_add(&bounds, sel->xyz + 3 * first, count);
    wpd_format fmt = wpd_format_from_name(path);
    if (fmt == WPD_FMT_NONE)
        return wpd_fail(err, WPD_E_USAGE, "%s: output must end in .las or .ply", path);
    if (wpd_layout_plan(in, &bounds, fmt, out, map, err))
        return -1;
    if (sel->moved && needs_wider_coordinates(out, &bounds, sel->precision) &&
        wpd_layout_widen_coordinates(in, out, map, err)) {
        wpd_header_free(out);
        return -1;
    }
    int replaced;
    *label = -1;
    if (sel->edge && (*label = wpd_layout_add_label(out, WPD_EDGE_FIELD, WPD_EDGE_DESCRIPTION,
                                                    &replaced, err)) < 0) {
        wpd_header_free(out);
        return -1;
    }
    return 0;
}

/* Writes the points first..first+count of sel to path; the finished file
 * stays under its temporary name, described by *pending. */
static int write_points(const wpd_selection *sel, size_t first, size_t count,
                        const wpd_header *in, const char *path, const wpd_write_options *opt,
                        wpd_outfile *pending, wpd_error *err)
{
    wpd_header out;
    wpd_layout_map map;
    int label = -1;
    if (plan_output(sel, first, count, in, path, &out, &map, &label, err))
        return -1;
    wpd_batch src, dst;
    int rc = -1;
    wpd_writer *w = NULL;
    memset(&src, 0, sizeof src);
    memset(&dst, 0, sizeof dst); /* freed below even when src fails */
    if (wpd_batch_init(&src, 65536, sel->record_size) ||
        wpd_batch_init(&dst, 65536, out.schema.record_size)) {
        wpd_fail(err, WPD_E_MEMORY, "%s: out of memory for the write buffers", path);
        goto done;
    }
    if (!(w = wpd_writer_open(path, &out, opt, err)))
        goto done;
    for (size_t start = first; start < first + count; start += src.cap) {
        src.n = first + count - start < src.cap ? first + count - start : src.cap;
        memcpy(src.records, sel->records + start * sel->record_size, src.n * sel->record_size);
        memcpy(src.xyz, sel->xyz + 3 * start, 3 * src.n * sizeof *src.xyz);
        wpd_layout_apply(&map, &in->schema, &out.schema, &src, &dst);
        if (label >= 0)
            wpd_layout_set_labels(&out.schema.dims[label], &dst, sel->edge + start);
        if (wpd_writer_write(w, &dst, err))
            goto done;
    }
    rc = wpd_writer_close_pending(w, pending, err);
    w = NULL;
done:
    wpd_writer_abort(w);
    wpd_batch_free(&src);
    wpd_batch_free(&dst);
    wpd_header_free(&out);
    return rc;
}

int wpd_selection_write(const wpd_selection *sel, size_t first, size_t count,
                        const wpd_header *in, const char *path, const wpd_write_options *opt,
                        wpd_outfile *pending, wpd_error *err)
{
    return write_points(sel, first, count, in, path, opt, pending, err);
}

const char *wpd_per_input_path(const char *outdir, const char *input, char *buf, size_t size)
{
    char base[1024];
    snprintf(base, sizeof base, "%s", input);
    snprintf(buf, size, "%s/%s", outdir, basename(base));
    return buf;
}

int wpd_selection_write_per_input(const wpd_selection *sel, const wpd_cloud *cloud,
                                  const uint64_t *file_count, const char *outdir,
                                  const wpd_write_options *opt, wpd_outfile *pending,
                                  wpd_error *err)
{
    /* All outputs or none: a run that stopped halfway must not leave half
     * the folder done: with --skip-existing the next run would resample
     * the other half on its own, with a seam and a different count. */
    int nfiles = wpd_cloud_nfiles(cloud);
    wpd_outfile_clear_all(pending, nfiles);
    int rc = 0;
    uint64_t file_start = 0;
    size_t first = 0;
    for (int f = 0; f < nfiles && rc == 0; f++) {
        const wpd_header *in = wpd_cloud_header(cloud, f);
        uint64_t file_end = file_start + file_count[f];
        size_t count = 0;
        while (first + count < sel->n && sel->gid[first + count] < file_end)
            count++;
        char path[2048];
        wpd_per_input_path(outdir, in->path, path, sizeof path);
        rc = write_points(sel, first, count, in, path, opt, &pending[f], err);
        first += count;
        file_start = file_end;
    }
    if (rc)
        wpd_outfile_abort_all(pending, nfiles);
    else
        wpd_test_stall("per-input");
    return rc;
}

void wpd_selection_free(wpd_selection *sel)
{
    free(sel->gid);
    free(sel->xyz);
    free(sel->records);
    memset(sel, 0, sizeof *sel);
}
