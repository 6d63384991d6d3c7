/* classes.h - resampling by class: --drop-class, --keep-class and
 * --class-count (docs/algorithm.md, section 6).
 *
 * Every point has a class (io/cloud.h: an integer field). A class is
 *   dropped   removed before anything else;
 *   kept      copied to the output untouched (records and coordinates);
 *   counted   resampled on its own to its exact count, with its own radius;
 *   the rest  (every other class) resampled together to the rest's count.
 * Each resampled group is one full run of the driver (resample.h) over the
 * cloud filtered to that group: its samples are exactly those of a run over
 * a file holding only its points, whatever the other classes (groups do not
 * constrain each other). A group whose count is at or above its points is
 * kept whole. The output is never held: the records pass
 * (wpd_class_stream_records) reads the cloud under output_filter and takes
 * each point's class: a kept class's point or a whole group's is written
 * as it is, a resampled group's point when it is that group's next sample
 * (the group's runs merged into its own index order: the index among the
 * group's points). The histogram pass gives, per file, the count and box of
 * each group's and of the kept classes' points, so the output's counts and
 * boxes per file are known before its first record.
 */
#ifndef WPD_CLASSES_H
#define WPD_CLASSES_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/cloud.h"
#include "resample/resample.h"

/* The group of a class (wpd_class_result.group_of): its index, or one of
 * these. */
#define WPD_GROUP_DROPPED (-1)
#define WPD_GROUP_KEPT (-2)

/* A class's part in a run. */
typedef enum wpd_class_role {
    WPD_CLASS_REST = 0,       /* resampled with the other unnamed classes */
    WPD_CLASS_DROP,
    WPD_CLASS_KEEP,
    WPD_CLASS_COUNT           /* resampled to a count of its own */
} wpd_class_role;

typedef struct wpd_class_request {
    long cls;
    uint64_t count;
} wpd_class_request;

/* What the user asked. */
typedef struct wpd_class_options {
    wpd_dim field;                 /* the class field */
    const uint8_t *drop, *keep;    /* [WPD_CLASS_MAX + 1] 1: named, or NULL */
    const wpd_class_request *counts; /* --class-count, distinct classes */
    int ncounts;
    /* The rest's count: rest_count, or rest_percent % of the rest's points
     * when rest_percent >= 0. */
    uint64_t rest_count;
    double rest_percent;
} wpd_class_options;

/* One group of a run: the rest, or one counted class. */
typedef struct wpd_class_group {
    long cls;                      /* the counted class, -1 for the rest */
    uint64_t points, target;       /* its input points; the count asked */
    int whole;                     /* 1: target >= points, copied untouched */
    wpd_resample_result run;       /* its run (when not whole and points > 0): its
                                      samples' runs are read by the records pass */
} wpd_class_group;

/* Points in and out per class present in the input. */
typedef struct wpd_class_line {
    long cls;
    wpd_class_role role;
    uint64_t in, out;
} wpd_class_line;

typedef struct wpd_class_result {
    wpd_resample_result merged;    /* the output: count, file_samples, file_bounds
                                      (every group's samples and the kept points per
                                      file), record_size, moved, labelled,
                                      sharp_samples, input_points, nfiles, file_count
                                      (points not dropped: the cloud under
                                      output_filter); no samples (they stay with the
                                      groups); the other fields from the first group
                                      run, times summed over the runs */
    wpd_class_group *groups;       /* [ngroups]: the rest first, then the counts */
    int ngroups;
    wpd_class_line *lines;         /* [nlines], by class; out counted by the
                                      records pass */
    int8_t *group_of;              /* [WPD_CLASS_MAX + 1]: group index or WPD_GROUP_* */
    int nlines;
    uint64_t dropped;              /* points of dropped classes */
    wpd_point_filter output_filter; /* the classes not dropped: set it on the cloud for
                                      the records pass (valid until the result is freed) */
    uint8_t *output_accept;        /* its table (owned) */
    double histogram_seconds;
} wpd_class_result;

/* The role of class cls under o. */
wpd_class_role wpd_class_role_of(const wpd_class_options *o, long cls);

/* Resamples cloud by class under o: opt gives everything but the target
 * (opt->target is ignored). Classes named in o and absent from the input
 * get a notice on stderr unless quiet, as do counts that keep a whole
 * class. Returns 0 (out filled; free with wpd_class_result_free), or -1
 * with err set (WPD_E_INPUT when no point is left to write, or as
 * wpd_resample_run). */
int wpd_resample_by_class(wpd_cloud *cloud, const wpd_class_options *o,
                          const wpd_resample_options *opt, int quiet, wpd_class_result *out,
                          wpd_error *err);

void wpd_class_result_free(wpd_class_result *r);

/* The group of every class under o into group_of[WPD_CLASS_MAX + 1]: 0
 * the rest, 1 + i the i-th counted class, or WPD_GROUP_*. */
void wpd_class_groups_of(const wpd_class_options *o, int8_t *group_of);

/* The records pass of a run by class (wpd_resample_stream_records for
 * r): reads cloud once under r's output filter and hands every output
 * point (kept, whole group, or a group's sample with its coordinates and
 * label) to sink in input order with its record, then sets the output
 * count of r's lines. Each resampled group's runs are merged within
 * WPD_RUN_MERGE_BUDGET / groups. Returns 0, or -1 with err set (as
 * wpd_resample_stream_records). */
int wpd_class_stream_records(wpd_cloud *cloud, wpd_class_result *r, size_t mem_bytes,
                             int threads, wpd_progress *progress, wpd_sample_sink sink,
                             void *arg, wpd_error *err);

#endif
