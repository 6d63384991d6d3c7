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
 * kept whole. A merge pass puts every group's samples and the kept points
 * back in input order; their records come from the records pass
 * (wpd_resample_stream_records) over the cloud with output_filter set.
 */
#ifndef WPD_CLASSES_H
#define WPD_CLASSES_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "io/cloud.h"
#include "resample/resample.h"

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
    wpd_resample_result run;       /* its run (when not whole and points > 0); the
                                      arrays are freed once merged */
} wpd_class_group;

/* Points in and out per class present in the input. */
typedef struct wpd_class_line {
    long cls;
    wpd_class_role role;
    uint64_t in, out;
} wpd_class_line;

typedef struct wpd_class_result {
    wpd_resample_result merged;    /* every group's samples and the kept points, in
                                      input order (gid: index among the points not
                                      dropped: the cloud under output_filter); count,
                                      gid, xyz, edge, record_size, moved,
                                      input_points, nfiles,
                                      file_count; the other fields from the first group
                                      run, times summed over the runs */
    wpd_class_group *groups;       /* [ngroups]: the rest first, then the counts */
    int ngroups;
    wpd_class_line *lines;         /* [nlines], by class */
    int nlines;
    uint64_t dropped;              /* points of dropped classes */
    wpd_point_filter output_filter; /* the classes not dropped: set it on the cloud for
                                      the records pass (valid until the result is freed) */
    uint8_t *output_accept;        /* its table (owned) */
    double histogram_seconds, merge_seconds;
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

#endif
