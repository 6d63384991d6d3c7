/* write.h - the resampled points on their way to the output: the
 * selected input points with their new coordinates, in global index order,
 * their records read once more from the inputs as they are written
 * (resample.h, wpd_resample_stream_records), to one file or split into one
 * file per input. No record, and no point, is held for all points at once:
 * the per-file counts and boxes are known before.
 */
#ifndef WPD_RESAMPLE_WRITE_H
#define WPD_RESAMPLE_WRITE_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/cloud.h"
#include "common/progress.h"
#include "io/writer.h"
#include "par/par.h"
#include "resample/resample.h"

/* The records pass that hands the output points to sink (resample.h:
 * wpd_resample_stream_records over a merge of a run's samples, or
 * classes.h: wpd_class_stream_records), with its own data in src. */
typedef int (*wpd_records_source)(void *src, wpd_cloud *cloud, size_t mem_bytes, int threads,
                                  wpd_progress *progress, wpd_sample_sink sink, void *arg,
                                  wpd_error *err);

/* The records pass of one share of the output, the samples first ..
 * first + count - 1 in output order (resample.h,
 * wpd_resample_stream_share). */
typedef int (*wpd_records_share_source)(void *src, wpd_cloud *cloud, uint64_t first,
                                        uint64_t count, size_t mem_bytes, int threads,
                                        wpd_progress *progress, wpd_sample_sink sink,
                                        void *arg, wpd_error *err);

typedef struct wpd_selection {
    size_t n;                 /* output points */
    const uint64_t *file_samples; /* [nfiles] output points per input file */
    const wpd_bounds *file_bounds; /* [nfiles] their boxes (the layout needs them
                                 before the first record) */
    int moved;                /* 1: coordinates changed (smoothing) */
    double precision;         /* resolution the moved coordinates need */
    int labelled;             /* 1: write the sharp-feature labels as the field
                                 WPD_EDGE_FIELD (the source hands labels out) */
    wpd_records_source source;
    void *source_arg;
    wpd_records_share_source share_source; /* or NULL: the source cannot start
                                 mid-way (one process writes) */
    double *xyz_out;          /* [3n], or NULL: gets the coordinates written, in
                                 output order (--metrics measures them) */
} wpd_selection;

/* The output field of the sharp-feature labels (resample --edge-label). An
 * input field of that name is replaced: it keeps its place and type and
 * gets the labels. */
#define WPD_EDGE_FIELD "edge"
#define WPD_EDGE_DESCRIPTION "sharp feature (wpd --sharp)"

/* Where and how the outputs go. */
typedef struct wpd_selection_target {
    const char *path;         /* one output (format from its extension), or NULL */
    const char *outdir;       /* with path NULL: one output per input file */
    const wpd_write_options *opt;
    size_t mem_bytes;         /* the budget the records pass reads within */
    int threads;
    wpd_progress *progress;   /* may be NULL */
    const wpd_par *par;       /* the ranks (NULL: one process) */
    const char *tmpdir;       /* where a rank's part of the output waits */
} wpd_selection_target;

/* Writes sel, its points and records from sel->source reading cloud (as
 * the run read it: the same files, the same filter). Each output has the
 * layout wpd_layout_plan gives for its input header (the first file's for
 * one output; with the field WPD_EDGE_FIELD when sel->labelled) and is finished (flushed and closed) under its temporary name,
 * described by pending[k] (one output: pending[0]; per input: one per
 * input file, also those that get no point, written empty). The caller
 * renames them all with wpd_outfile_rename_all once every one is complete
 * (outputs appear together or not at all: a run stopped halfway must not
 * leave half a --per-input folder done, or --skip-existing would resample
 * the other half on its own); per input it keeps outdir's temporary
 * outputs tracked (wpd_tmpdir_track_outputs) until then. Returns 0, or -1
 * with err set and no new output left. */
int wpd_selection_write(const wpd_selection *sel, wpd_cloud *cloud,
                        const wpd_selection_target *target, wpd_outfile *pending,
                        wpd_error *err);

/* Whether the ranks of target->par (two or more) write sel together:
 * one output, a source that can start mid-way, no coordinates kept for
 * --metrics. The same on every rank. */
int wpd_selection_shared(const wpd_selection *sel, const wpd_selection_target *target);

/* wpd_selection_write by every rank (wpd_selection_shared): each reads the
 * records of its share of the samples (whole LAZ chunks, in output order)
 * and writes them, rank 0 into the output, the others into a part file in
 * target->tmpdir that is then copied into the output at its offset (an
 * exclusive prefix sum of the parts' bytes); rank 0 then completes the
 * header and tables from every part's facts and finishes the output under
 * its temporary name, in pending[0] (other ranks: pending may be NULL).
 * The bytes are those one process writes. Every rank calls it; it agrees
 * before each exchange (par.h). Returns 0, or -1 with err set and no
 * output or part left. */
int wpd_selection_write_shared(const wpd_selection *sel, wpd_cloud *cloud,
                               const wpd_selection_target *target, wpd_outfile *pending,
                               wpd_error *err);

/* The part file a rank after the first writes its share of output into
 * (wpd_selection_write_shared): "<tmpdir>/wpd-part<output's extension>",
 * the extension choosing the format; in buf. output may also be just an
 * extension (".las": what a sweep of stale parts looks for). */
const char *wpd_part_path(const char *tmpdir, const char *output, char *buf, size_t size);

/* Room for an output's path: what wpd_per_input_path writes into. */
#define WPD_PATH_BYTES 2048

/* The --per-input output of input: "<outdir>/<input's file name>", in buf
 * (WPD_PATH_BYTES of room). */
const char *wpd_per_input_path(const char *outdir, const char *input, char *buf, size_t size);


#endif
