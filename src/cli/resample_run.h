/* resample_run.h - the two ways `wpd resample` runs, behind one contract:
 * the cloud in memory as one block (wpd_run_block), or the out-of-core
 * engine (wpd_engine_run). Both fill the selection (samples in global
 * index order: absolute coordinates and input records), the finite points
 * per input file (for --per-input) and the run's facts for the summary and
 * the report. */
#ifndef WPD_RESAMPLE_RUN_H
#define WPD_RESAMPLE_RUN_H

#include "cli/report.h"
#include "cli/selection.h"
#include "common/progress.h"
#include "ooc/engine.h"
#include "wpd/wpd.h"

/* Memory the in-memory path needs for n points of record_size bytes. */
size_t wpd_in_memory_bytes(uint64_t n, uint32_t record_size);

/* Loads cloud and resamples it to target points with params (the
 * multiscale radius computed as the engine computes it). *file_count is
 * malloc'd. Returns 0 or -1 with err set. */
int wpd_run_in_memory(wpd_cloud *cloud, uint64_t target, const wpd_params *params,
                      wpd_progress *pg, wpd_selection *sel, uint64_t **file_count,
                      wpd_run_info *info, wpd_error *err);

/* Resamples cloud with the engine; *file_count and *tile_box are malloc'd.
 * --sharp is refused (not out of core yet). Returns 0 or -1 with err set. */
int wpd_run_out_of_core(wpd_cloud *cloud, const wpd_engine_options *eo, wpd_selection *sel,
                        uint64_t **file_count, double **tile_box, wpd_run_info *info,
                        wpd_error *err);

#endif
