/* report.h - what a resampling run did, printed as a summary or written
 * as the JSON report of `wpd resample --report FILE` (schema in
 * docs/report.md). */
#ifndef WPD_REPORT_H
#define WPD_REPORT_H

#include <stddef.h>
#include <stdint.h>

#include "common/error.h"
#include "spill/spill.h"
#include "wpd/wpd.h"

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
    uint64_t input_points, dropped;
    size_t count;
    double radius, radius_estimate;
    size_t first_pass_count, poisson_count;
    int passes, prune_passes;
    size_t open_cells, pulled;
    int tiles, colours;           /* 0: one block in memory */
    uint64_t largest_tile;
    const double *tile_box;       /* [6 tiles] absolute min xyz, max xyz */
    wpd_spill_stats spill;
    double t_load, t_scan, t_tile, t_radius, t_poisson, t_exact, t_smooth, t_write, t_total;
    long peak_rss_kb;
    const char *metrics_json;     /* `wpd metrics --json` of the run, or NULL */
} wpd_run_info;

/* Writes info as one JSON object to path (temporary file, then renamed).
 * Returns 0 or -1 with err set. */
int wpd_report_write(const char *path, const wpd_run_info *info, wpd_error *err);

#endif
