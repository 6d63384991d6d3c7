/* exact.h - the exact count through tiles (internal to src/resample/;
 * the sweep's design in exact_internal.h). */
#ifndef WPD_RESAMPLE_EXACT_H
#define WPD_RESAMPLE_EXACT_H

#include "common/error.h"
#include "resample/run.h"

/* Coverage-aware elimination down to exactly n samples. */
int wpd_exact_phase(wpd_run *run, wpd_error *err);

#endif
