/* write.c - the selection written by one process (write.h): each output
 * laid out from its input, fed by the records pass, finished under its
 * temporary name. */
#include "resample/write.h"

#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/testhook.h"
#include "io/layout.h"
#include "resample/resample.h"
#include "resample/write_internal.h"

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
static int plan_output(const wpd_selection *sel, const wpd_bounds *box, const wpd_header *in,
                       const char *path, wpd_header *out, wpd_layout_map *map, int *label,
                       wpd_error *err)
{
    wpd_bounds bounds = *box;
    wpd_format fmt = wpd_format_from_name(path);
    if (fmt == WPD_FMT_NONE)
        return wpd_fail(err, WPD_E_USAGE, "%s: output must end in .las, .laz or .ply", path);
    if (wpd_layout_plan(in, &bounds, fmt, out, map, err))
        return -1;
    if (sel->moved && needs_wider_coordinates(out, &bounds, sel->precision) &&
        wpd_layout_widen_coordinates(in, out, map, err)) {
        wpd_header_free(out);
        return -1;
    }
    int replaced;
    *label = -1;
    if (sel->labelled && (*label = wpd_layout_add_label(out, WPD_EDGE_FIELD, WPD_EDGE_DESCRIPTION,
                                                    &replaced, err)) < 0) {
        wpd_header_free(out);
        return -1;
    }
    return 0;
}

const wpd_header *wpd_writing_input(const wpd_writing *ws, int k)
{
    return wpd_cloud_header(ws->cloud, ws->target->path ? 0 : k);
}

/* Opens the writer of output k (path: its name, which chooses the
 * format), or with part a part writer of it into that file (io/writer.h). */
int wpd_writing_open(wpd_writing *ws, int k, const char *path, const char *part,
                       wpd_error *err)
{
    if (plan_output(ws->sel, &ws->box[k], wpd_writing_input(ws, k), path, &ws->out, &ws->map,
                    &ws->label, err))
        return -1;
    ws->w = part ? wpd_writer_open_part(part, &ws->out, ws->target->opt, err)
                 : wpd_writer_open(path, &ws->out, ws->target->opt, err);
    if (!ws->w) {
        wpd_header_free(&ws->out);
        return -1;
    }
    ws->open = 1;
    return 0;
}

/* Opens output ws->done. */
int wpd_writing_open_next(wpd_writing *ws, wpd_error *err)
{
    char buf[WPD_PATH_BYTES];
    const char *path = ws->target->path;
    if (!path)
        path = wpd_per_input_path(ws->target->outdir, wpd_writing_input(ws, ws->done)->path, buf,
                                  sizeof buf);
    return wpd_writing_open(ws, ws->done, path, NULL, err);
}

/* Finishes the open output under its temporary name (pending[done]). */
int wpd_writing_close(wpd_writing *ws, wpd_error *err)
{
    int rc = wpd_writer_close_pending(ws->w, &ws->pending[ws->done], err);
    ws->w = NULL;
    wpd_header_free(&ws->out);
    ws->open = 0;
    ws->done++;
    return rc;
}

/* Finishes every output before k (empty ones included). */
int wpd_writing_finish_before(wpd_writing *ws, int k, wpd_error *err)
{
    while (ws->done < k)
        if ((!ws->open && wpd_writing_open_next(ws, err)) || wpd_writing_close(ws, err))
            return -1;
    return 0;
}

/* Finishes every output before k and opens k. */
static int advance_to(wpd_writing *ws, int k, wpd_error *err)
{
    if (wpd_writing_finish_before(ws, k, err))
        return -1;
    return ws->open || k >= ws->nout ? 0 : wpd_writing_open_next(ws, err);
}

/* The sink of the records pass: n samples of input file `file` in the
 * input layout, to the open output's layout, written. */
int wpd_writing_sink(void *arg, int file, const double *xyz, const uint8_t *edge,
                         const uint8_t *records, size_t n, wpd_error *err)
{
    wpd_writing *ws = arg;
    int k = ws->target->path ? 0 : file;
    if (advance_to(ws, k, err))
        return -1;
    const wpd_header *in = wpd_writing_input(ws, k);
    if (ws->dst.cap < n || ws->dst.record_size != ws->out.schema.record_size) {
        wpd_batch_free(&ws->dst);
        if (wpd_batch_init(&ws->dst, n, ws->out.schema.record_size) || ws->dst.cap < n)
            return wpd_fail(err, WPD_E_MEMORY, "out of memory for the write buffers");
    }
    wpd_batch src = {n, n, in->schema.record_size, (uint8_t *)records, (double *)xyz};
    wpd_layout_apply(&ws->map, &in->schema, &ws->out.schema, &src, &ws->dst);
    if (ws->label >= 0)
        wpd_layout_set_labels(&ws->out.schema.dims[ws->label], &ws->dst, edge);
    if (ws->written + n > ws->limit)
        return wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                        wpd_cloud_header(ws->cloud, 0)->path);
    if (ws->sel->xyz_out)
        memcpy(ws->sel->xyz_out + 3 * ws->written, xyz, 3 * n * sizeof *xyz);
    ws->written += n;
    return wpd_writer_write(ws->w, &ws->dst, err);
}

/* The box of each output's points: one output's is every file's. */
int wpd_writing_boxes(wpd_writing *ws, wpd_error *err)
{
    int nfiles = wpd_cloud_nfiles(ws->cloud);
    ws->nout = ws->target->path ? 1 : nfiles;
    ws->box = malloc((size_t)ws->nout * sizeof *ws->box);
    if (!ws->box)
        return wpd_fail(err, WPD_E_MEMORY, "out of memory for %d outputs", ws->nout);
    for (int k = 0; k < ws->nout; k++)
        ws->box[k] = ws->sel->file_bounds[k];
    for (int f = 1; ws->target->path && f < nfiles; f++)
        wpd_bounds_union(&ws->box[0], &ws->sel->file_bounds[f]);
    return 0;
}

int wpd_selection_write(const wpd_selection *sel, wpd_cloud *cloud,
                        const wpd_selection_target *target, wpd_outfile *pending,
                        wpd_error *err)
{
    wpd_writing ws = {.sel = sel, .cloud = cloud, .target = target, .pending = pending,
                  .limit = sel->n};
    int rc = wpd_writing_boxes(&ws, err);
    if (rc == 0)
        wpd_outfile_clear_all(pending, ws.nout);
    if (rc == 0)
        rc = sel->source(sel->source_arg, cloud, target->mem_bytes, target->threads,
                         target->progress, wpd_writing_sink, &ws, err);
    if (rc == 0 && ws.written != sel->n)
        rc = wpd_fail(err, WPD_E_INPUT, "%s: the inputs changed while being resampled",
                      wpd_cloud_header(cloud, 0)->path);
    if (rc == 0)
        rc = advance_to(&ws, ws.nout, err); /* the outputs after the last point */
    if (ws.open) {
        wpd_writer_abort(ws.w);
        wpd_header_free(&ws.out);
    }
    wpd_batch_free(&ws.dst);
    free(ws.box);
    if (rc)
        wpd_outfile_abort_all(pending, ws.nout ? ws.nout : 1);
    else if (!target->path)
        wpd_test_stall("per-input");
    return rc;
}

const char *wpd_part_path(const char *tmpdir, const char *output, char *buf, size_t size)
{
    const char *dot = strrchr(output, '.');
    snprintf(buf, size, "%s/wpd-part%s", tmpdir, dot ? dot : "");
    return buf;
}

const char *wpd_per_input_path(const char *outdir, const char *input, char *buf, size_t size)
{
    char base[1024];
    snprintf(base, sizeof base, "%s", input);
    snprintf(buf, size, "%s/%s", outdir, basename(base));
    return buf;
}

