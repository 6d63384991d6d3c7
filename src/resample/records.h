/* records.h - the records pass under any choice of output points
 * (internal to src/resample/: wpd_resample_stream_records in resample.h
 * for a run's samples, classes.h for a run by class). */
#ifndef WPD_RECORDS_H
#define WPD_RECORDS_H

#include "io/pass.h"
#include "resample/resample.h"

/* The output points of batch pb from its point *at on, at most a buffer's
 * worth: into *v (global indices ascending within the batch, coordinates,
 * labels or NULL; valid until the next call), *at moved past the points
 * considered (pb->batch->n once the batch is done). Returns 0, or -1 with
 * err set. */
typedef int (*wpd_records_picker)(void *arg, const wpd_pass_batch *pb, size_t *at,
                                  wpd_sample_view *v, wpd_error *err);

/* The records pass (resample.h, wpd_resample_stream_records) with the
 * output points chosen by pick; in_use: bytes the picker holds during the
 * pass (for the lanes' budget). The caller checks afterwards that the
 * picker saw every point it expected. */
int wpd_records_pass(wpd_cloud *cloud, wpd_records_picker pick, void *pick_arg, size_t in_use,
                     size_t mem_bytes, int threads, wpd_progress *progress, wpd_sample_sink sink,
                     void *arg, wpd_error *err);

#endif
