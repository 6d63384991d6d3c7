/* selection.h - the resampled points on their way to the output: records
 * of the selected input points with their new coordinates, in global index
 * order, written to one file or split into one file per input. */
#ifndef WPD_SELECTION_H
#define WPD_SELECTION_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/cloud.h"
#include "io/writer.h"

typedef struct wpd_selection {
    size_t n;
    uint64_t *gid;            /* [n] ascending global indices (finite points, in
                                 input order over all files) */
    double *xyz;              /* [3n] absolute coordinates */
    uint8_t *records;         /* [n * record_size] input records */
    uint32_t record_size;
    int moved;                /* 1: coordinates changed (smoothing) */
    double precision;         /* resolution the moved coordinates need */
    const uint8_t *edge;      /* [n] sharp-feature labels to write as the field
                                 WPD_EDGE_FIELD, or NULL: none written */
} wpd_selection;

/* The output field of the sharp-feature labels (resample --edge-label). An
 * input field of that name is replaced: it keeps its place and type and
 * gets the labels. */
#define WPD_EDGE_FIELD "edge"
#define WPD_EDGE_DESCRIPTION "sharp feature (wpd --sharp)"

/* Writes sel to path (format from its extension), in the layout that
 * wpd_layout_plan gives for the input header in (with the field
 * WPD_EDGE_FIELD when sel->edge is set), finished (flushed and
 * closed) under its temporary name, described by *pending: the caller
 * renames it with wpd_outfile_rename_all (with the report, if any).
 * Returns 0, or -1 with nothing left. */
int wpd_selection_write(const wpd_selection *sel, size_t first, size_t count,
                        const wpd_header *in, const char *path, const wpd_write_options *opt,
                        wpd_outfile *pending, wpd_error *err);

/* The --per-input output of input: "<outdir>/<input's file name>", in buf. */
const char *wpd_per_input_path(const char *outdir, const char *input, char *buf, size_t size);

/* Writes one output per input file into outdir (same file name, same
 * format as the input): the points of sel whose global index falls in that
 * file (file_count[i] finite points each, in order). Files that receive no
 * point are still written (empty). All appear together: each is finished
 * under its temporary name, described by pending[i] (one per input file),
 * and the caller renames them all with wpd_outfile_rename_all once every
 * one is complete; it also keeps outdir's temporary outputs tracked
 * (wpd_tmpdir_track_outputs) until then, as they can be more than the
 * signal handlers' registry holds one by one. Returns 0, or -1 with no new
 * output left (the outputs an earlier run made stay as they were). */
int wpd_selection_write_per_input(const wpd_selection *sel, const wpd_cloud *cloud,
                                  const uint64_t *file_count, const char *outdir,
                                  const wpd_write_options *opt, wpd_outfile *pending,
                                  wpd_error *err);

void wpd_selection_free(wpd_selection *sel);

#endif
