/* merge.h - the merge (internal to src/resample/). */
#ifndef WPD_RESAMPLE_MERGE_H
#define WPD_RESAMPLE_MERGE_H

#include "common/error.h"
#include "resample/run.h"

/* Each tile's samples as a sorted run of the result (absolute
 * coordinates), the per-file counts and boxes. */
int wpd_merge_phase(wpd_run *run, wpd_error *err);

#endif
