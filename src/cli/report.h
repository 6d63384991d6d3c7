/* report.h - what a resampling run did, printed as a summary or written
 * as the JSON report of `wpd resample --report FILE` (schema in
 * docs/report.md). */
#ifndef WPD_REPORT_H
#define WPD_REPORT_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "common/outfile.h"
#include "resample/classes.h"
#include "resample/resample.h"

typedef struct wpd_run_info {
    /* what was asked */
    int ninputs;
    char *const *inputs;
    const char *output;           /* or NULL with per_input */
    const char *per_input;
    uint64_t target;
    size_t mem_bytes;
    int threads;
    const wpd_params *params;
    /* what happened */
    const wpd_resample_result *run;
    const wpd_class_result *classes; /* a run by class, or NULL */
    uint64_t dropped;             /* non-finite points dropped */
    double t_write, t_total;
    long peak_rss_kb;             /* the largest over the ranks */
    uint64_t records_cached;      /* records read back from the record cache */
    int ranks;                    /* processes of an MPI run (1: a plain run) */
    uint64_t exchanged_bytes;     /* payload the ranks handed each other (par.h) */
    int writers;                  /* ranks that wrote a share of the output */
    const char *metrics_json;     /* `wpd metrics --json` of the run, or NULL */
    const struct wpd_cli_collection *collection; /* a collection's night, or NULL */
} wpd_run_info;

/* Writes info as one JSON object to a temporary file beside path,
 * finished (flushed and closed) and described by *pending: the caller
 * renames it with the outputs (wpd_outfile_rename_all), so that a report
 * that cannot be written fails the run before any output is in place.
 * Returns 0, or -1 with err set and nothing left. */
int wpd_report_write(const char *path, const wpd_run_info *info, wpd_outfile *pending,
                     wpd_error *err);

/* "rest", "drop", "keep" or "count". */
const char *wpd_class_role_name(wpd_class_role role);

#endif
